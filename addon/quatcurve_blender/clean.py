"""Cleaning captured rotations in Blender: flips, spikes and jitter removed on the sphere of rotations.

Plain functions, no operator state: the `quatcurve.clean` operator, `cli.py --clean` and `batch --clean`
call the same code. The math is native (`quatcurve.clean_rotations`, docs/clean.md): flips removed,
the clip's noise estimated, spikes found and replaced by the curve through their neighbours, then a
smoothing that stays within `deviation` of every frame that is not a spike. This module only moves
arrays between targets (reduce.read_target: Blender's evaluation of the rotation channels at every
whole frame and key), the cleaner on arrays (clean_arrays.clean_channels: the same mode back,
continuous), and write.py (writing).

    found = targets.gather_targets(bpy.context, verb="clean")
    result = clean.clean(found, clean.CleanSettings(deviation=0.0))   # 0: 2.5 × the clip's noise
    print(result.summary())

What is written: the cleaned rotation at every sample frame, as LINEAR keys (Blender plays the
cleaned rotation exactly at those frames), or with `reduce` on, those keys reduced by the proved
reduction (reduce.reduce_values against the dense keys' own playback: within `tolerance` of them at
every instant). Euler rows stay on the original's branch and turns, quaternions hemisphere-continuous
from the first row's sign, axis-angle from its axis side and turn: the rotation at every frame is the
cleaned one. Locations and scales are not touched. Into a new action by default, so the
capture is kept.

Refused (ReduceError's message names the target and cause, nothing written): targets reduce refuses
(NLA only without an action, drivers, library data, F-curve modifiers), loops (Cycles modifiers: a
capture clip is not cleaned as a loop), and clips of fewer than 3 frames.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import reduce, targets, write
from .clean_arrays import clean_channels
from .workers import parallel_map
from .targets import TargetError, num


class CleanError(TargetError, ValueError):
    """A clean that cannot be done; the message names the target and what is wrong. Raised before
    anything is written."""


@dataclass
class CleanSettings:
    """deviation: degrees, how far the cleaned rotation may stray from each frame that is not a spike;
    0 takes 2.5 × the clip's estimated noise, target by target. spikes: find and replace spikes.
    reduce: reduce the cleaned keys (BEZIER, per channel) within `tolerance` degrees of them at every
    instant; off: one LINEAR key per sample frame. new_action: write into a copy of each action."""
    deviation: float = 0.0
    spikes: bool = True
    reduce: bool = False
    tolerance: float = 0.1
    new_action: bool = True


def check_settings(settings):
    for name in ("deviation", "tolerance"):
        value = getattr(settings, name)
        if not (value >= 0) or not math.isfinite(value):
            raise CleanError("%s %r°: must be a finite angle of 0 or more" % (name, value))


@dataclass
class TargetResult:
    name: str
    mode: str
    frames: int                 # sample frames cleaned
    keys_before: int
    keys_after: int
    noise_deg: float            # the clip's noise σ, estimated
    deviation_deg: float        # the bound used at the frames that are not spikes
    max_deviation_deg: float    # the largest angle to the original over those frames
    spikes: list                # frames replaced
    largest_spike_deg: float    # the largest departure of a replaced frame from its neighbours' curve
    flips: int                  # flips removed: quaternion sign flips, Euler branch or turn jumps
    action: str
    reduced_text: str = ""      # with reduce: the proved bound against the dense cleaned keys

    def line(self):
        spikes = ("%d spike frame%s replaced (%s; largest %.2f°)" % (
            len(self.spikes), "" if len(self.spikes) == 1 else "s", ", ".join(num(f) for f in self.spikes[:8])
            + (", …" if len(self.spikes) > 8 else ""), self.largest_spike_deg) if self.spikes else "no spikes")
        text = ("%s (%s): %d frames, noise %.3f°, within %.4f° of every other frame (bound %.4f°), %s, %d flip%s "
                "removed, %d → %d keys in '%s'" % (
                    self.name, self.mode, self.frames, self.noise_deg, self.max_deviation_deg, self.deviation_deg,
                    spikes, self.flips, "" if self.flips == 1 else "s", self.keys_before, self.keys_after, self.action))
        if self.reduced_text:
            text += "; reduced: " + self.reduced_text
        return text


@dataclass
class CleanResult:
    settings: CleanSettings
    targets: list = field(default_factory=list)
    seconds: float = 0.0

    @property
    def spike_frames(self):
        return sum(len(t.spikes) for t in self.targets)

    def summary(self):
        spiked = [t for t in self.targets if t.spikes]
        spikes = ("%d spike frame%s replaced on %s (largest %.2f°)" % (
            self.spike_frames, "" if self.spike_frames == 1 else "s", ", ".join(t.name for t in spiked[:6])
            + (", …" if len(spiked) > 6 else ""), max(t.largest_spike_deg for t in spiked)) if spiked else "no spikes")
        worst = max((t.max_deviation_deg for t in self.targets), default=0.0)
        return ("%d target%s: %s, %d flip%s removed, within %.4f° of every other frame, "
                "rotation keys %s → %s, %.2f s" % (
                    len(self.targets), "" if len(self.targets) == 1 else "s", spikes,
                    sum(t.flips for t in self.targets), "" if sum(t.flips for t in self.targets) == 1 else "s",
                    worst, f"{sum(t.keys_before for t in self.targets):,}",
                    f"{sum(t.keys_after for t in self.targets):,}", self.seconds))

    def lines(self):
        return [t.line() for t in self.targets]


@dataclass(eq=False)
class _Item:
    read: reduce.TargetReduce
    cleaned: object = None      # quatcurve.CleanResult
    values: np.ndarray = None   # (N, C) cleaned channel values
    flips: int = 0
    reduced: reduce.ReducedChannels = None


def clean(found, settings):
    """Cleans the rotation keys of `found` (targets.Target); returns a CleanResult. Raises CleanError
    (nothing written) when a setting or a target is unusable."""
    begin = time.perf_counter()
    check_settings(settings)
    if not found:
        raise CleanError("Nothing to clean: no targets")
    items = []
    try:
        for target in found:
            targets.check_editable(target, settings.new_action)
            read = reduce.read_target(target)
            if read.loop is not None:
                raise CleanError("%s: %s loops (Cycles modifiers): clean works on a clip, not a loop (remove the "
                                 "modifiers first)" % (target.name, read.prop))
            if len(read.frames) < 3:
                raise CleanError("%s: %d frame%s of %s: clean needs at least 3" % (
                    target.name, len(read.frames), "" if len(read.frames) == 1 else "s", read.prop))
            items.append(_Item(read))
    except TargetError as error:
        raise CleanError(str(error)) from error
    deviation = math.radians(settings.deviation) if settings.deviation > 0 else None
    tolerance = math.radians(settings.tolerance)

    def work(item):
        read = item.read
        try:
            cleaned = clean_channels(read.frames, read.values, read.mode, deviation=deviation, spikes=settings.spikes)
            item.cleaned, item.values, item.flips = cleaned.result, cleaned.values, cleaned.flips
            if settings.reduce:
                dense = [(read.frames, item.values[:, c], np.column_stack([read.frames, item.values[:, c]]),
                          np.column_stack([read.frames, item.values[:, c]])) for c in range(item.values.shape[1])]
                item.reduced = reduce.reduce_values(read.frames, item.values, read.mode, tolerance, "BEZIER", False,
                                                    original=(dense, "LINEAR"))
        except ValueError as error:
            raise CleanError("%s: %s" % (read.target.name, error)) from error
        return item

    done = parallel_map(work, items)  # everything computed before the first write
    writes = []
    for item in done:
        read = item.read
        if item.reduced is not None:
            keys, interpolation = item.reduced.keys, "BEZIER"
        else:
            keys = [(read.frames, item.values[:, c], None, None) for c in range(item.values.shape[1])]
            interpolation = "LINEAR"
        writes.append(write.RotationWrite(read.target, read.mode, keys, interpolation, replace=(read.prop,)))
    actions = write.write_rotations(writes, settings.new_action, "cleaned")
    result = CleanResult(settings)
    for item, w, action in zip(done, writes, actions):
        read, c = item.read, item.cleaned
        spikes = [float(read.frames[i]) for i in c.spike_frames]
        result.targets.append(TargetResult(
            read.target.name, read.mode, len(read.frames), read.keys_before, w.key_count, math.degrees(c.noise),
            math.degrees(c.deviation), math.degrees(c.max_deviation), spikes,
            max((math.degrees(d) for d in c.spike_departures), default=0.0), item.flips, action.name,
            item.reduced.error_text(settings.tolerance) if item.reduced is not None else ""))
    result.seconds = time.perf_counter() - begin
    return result
