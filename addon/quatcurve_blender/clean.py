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

error='DISTANCE' (clean_distance): per armature, the bound is on the virtual vertices (reduce's
definition, skeleton.py): every bone's tail and shell points in the armature's space within `distance`
of the captured pose at every frame that is not a spike of the bone or of a parent. Each selected
bone is cleaned with an angle budget (the distance over the farthest its subtree's vertices reach
from its head); the pose is measured natively (quatcurve.Skeleton.vertex_distances on the written
float32 values) and the budgets of a chain that exceeds it are tightened until every frame holds.

Refused (ReduceError's message names the target and cause, nothing written): targets reduce refuses
(drivers, library data, F-curve modifiers), loops (Cycles modifiers: a
capture clip is not cleaned as a loop), and clips of fewer than 3 frames; under DISTANCE what
reduce's distance bound refuses (skeleton.py: constraints, inherit scale modes, …) and `reduce`.
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import native, reduce, targets, write
from .clean_arrays import clean_channels
from .workers import parallel_map
from .targets import TargetError, num


class CleanError(TargetError, ValueError):
    """A clean that cannot be done; the message names the target and what is wrong. Raised before
    anything is written."""


DEVIATION_FACTOR = 2.5   # the default bound: 2.5 × the clip's noise σ (docs/clean.md, Defaults)
DISTANCE_ROUNDS = 30     # cleans of a chain under DISTANCE before giving up (each tightens its budgets)


@dataclass
class CleanSettings:
    """deviation: degrees, how far the cleaned rotation may stray from each frame that is not a spike;
    0 takes 2.5 × the clip's estimated noise, target by target. spikes: find and replace spikes.
    reduce: reduce the cleaned keys (BEZIER, per channel) within `tolerance` degrees of them at every
    instant; off: one LINEAR key per sample frame. new_action: write into a copy of each action.

    error: 'ANGLE' (the default: `deviation`, target by target) or 'DISTANCE' (per armature, every
    virtual vertex within `distance` of the captured pose at the frames that are not spikes;
    `deviation` is not used; `reduce` is refused). distance, shell: scene units, as reduce's; shell 0
    takes reduce's 10 cm in real size, distance 0 the noise's own reach: the largest 2.5·σ·R over the
    armature's selected bones (σ a bone's noise estimate, R the farthest its subtree's virtual
    vertices get from its head)."""
    deviation: float = 0.0
    spikes: bool = True
    reduce: bool = False
    tolerance: float = 0.1
    new_action: bool = True
    error: str = "ANGLE"
    distance: float = 0.0
    shell: float = 0.0


def check_settings(settings):
    for name in ("deviation", "tolerance"):
        value = getattr(settings, name)
        if not (value >= 0) or not math.isfinite(value):
            raise CleanError("%s %r°: must be a finite angle of 0 or more" % (name, value))
    if settings.error not in reduce.ERRORS:
        raise CleanError("error %r: unknown (expected ANGLE or DISTANCE)" % (settings.error,))
    for name in ("distance", "shell"):
        value = getattr(settings, name)
        if not (value >= 0) or not math.isfinite(value):
            raise CleanError("%s %r: must be a finite length of 0 or more (0: the default)" % (name, value))
    if settings.error == "DISTANCE" and settings.reduce:
        raise CleanError("reduce: its bound is an angle, not a distance; clean with error DISTANCE and no reduce, "
                         "then reduce the cleaned action with Reduce (error Distance)")


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
    distance_text: str = ""     # DISTANCE: the worst distance of the bone's own virtual vertices, with units

    def line(self):
        spikes = ("%d spike frame%s replaced (%s; largest %.2f°)" % (
            len(self.spikes), "" if len(self.spikes) == 1 else "s", ", ".join(num(f) for f in self.spikes[:8])
            + (", …" if len(self.spikes) > 8 else ""), self.largest_spike_deg) if self.spikes else "no spikes")
        if self.distance_text:  # the angle bound is the budget the distance gave this bone
            within = "virtual vertices within %s, rotation within %.4f° (budget %.4f°) of every other frame" % (
                self.distance_text, self.max_deviation_deg, self.deviation_deg)
        else:
            within = "within %.4f° of every other frame (bound %.4f°)" % (self.max_deviation_deg, self.deviation_deg)
        text = ("%s (%s): %d frames, noise %.3f°, %s, %s, %d flip%s removed, %d → %d keys in '%s'" % (
                    self.name, self.mode, self.frames, self.noise_deg, within, spikes, self.flips,
                    "" if self.flips == 1 else "s", self.keys_before, self.keys_after, self.action))
        if self.reduced_text:
            text += "; reduced: " + self.reduced_text
        return text


@dataclass
class CleanResult:
    settings: CleanSettings
    targets: list = field(default_factory=list)
    seconds: float = 0.0
    # DISTANCE: the bound used (the largest over the armatures when each took its default) and the
    # shell, the worst virtual-vertex distance over the frames that are not spikes and where it is
    # (armature/bone, frame, vertex), in scene units; units as reduce.ReduceResult's
    distance: float = None
    shell: float = None
    worst_distance: float = 0.0
    worst_where: str = ""
    units: tuple = None

    def length(self, value):
        return reduce.length_text(value, *(self.units or ("METRIC", 1.0)))

    @property
    def spike_frames(self):
        return sum(len(t.spikes) for t in self.targets)

    def summary(self):
        spiked = [t for t in self.targets if t.spikes]
        spikes = ("%d spike frame%s replaced on %s (largest %.2f°)" % (
            self.spike_frames, "" if self.spike_frames == 1 else "s", ", ".join(t.name for t in spiked[:6])
            + (", …" if len(spiked) > 6 else ""), max(t.largest_spike_deg for t in spiked)) if spiked else "no spikes")
        if self.distance is not None:
            within = "virtual vertices within %s of every other frame (bound %s, shell %s; %s)" % (
                self.length(self.worst_distance), self.length(self.distance), self.length(self.shell),
                self.worst_where or "-")
        else:
            within = "within %.4f° of every other frame" % max((t.max_deviation_deg for t in self.targets),
                                                               default=0.0)
        return ("%d target%s: %s, %d flip%s removed, %s, rotation keys %s → %s, %.2f s" % (
                    len(self.targets), "" if len(self.targets) == 1 else "s", spikes,
                    sum(t.flips for t in self.targets), "" if sum(t.flips for t in self.targets) == 1 else "s",
                    within, f"{sum(t.keys_before for t in self.targets):,}",
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
    noise: float = None         # DISTANCE: the clip's σ (radians), estimated once, kept over the rounds
    budget: float = None        # DISTANCE: the angle (radians) the bone is cleaned within
    distance: float = None      # DISTANCE: the worst distance of its own virtual vertices (scene units)


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
    if settings.error == "DISTANCE":
        groups = distance_groups(found, items, settings)

    def work(item):
        read = item.read
        try:
            if item.budget is not None:
                cleaned = clean_channels(read.frames, read.values, read.mode, deviation=item.budget, noise=item.noise,
                                         spikes=settings.spikes)
            else:
                cleaned = clean_channels(read.frames, read.values, read.mode, deviation=deviation,
                                         spikes=settings.spikes)
            item.cleaned, item.values, item.flips = cleaned.result, cleaned.values, cleaned.flips
            if settings.reduce:
                dense = [(read.frames, item.values[:, c], np.column_stack([read.frames, item.values[:, c]]),
                          np.column_stack([read.frames, item.values[:, c]])) for c in range(item.values.shape[1])]
                item.reduced = reduce.reduce_values(read.frames, item.values, read.mode, tolerance, "BEZIER", False,
                                                    original=(dense, "LINEAR"))
        except ValueError as error:
            raise CleanError("%s: %s" % (read.target.name, error)) from error
        return item

    if settings.error == "DISTANCE":
        for group in groups:
            clean_distance(group, work, settings.distance)
        done = items
    else:
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
    if settings.error == "DISTANCE":
        units = bpy_scene().unit_settings
        worst = max(groups, key=lambda g: g.worst)
        result.distance, result.shell = max(g.distance for g in groups), groups[0].shell
        result.worst_distance, result.worst_where = worst.worst, worst.where
        result.units = (units.system, units.scale_length or 1.0)
    for item, w, action in zip(done, writes, actions):
        read, c = item.read, item.cleaned
        spikes = [float(read.frames[i]) for i in c.spike_frames]
        result.targets.append(TargetResult(
            read.target.name, read.mode, len(read.frames), read.keys_before, w.key_count, math.degrees(c.noise),
            math.degrees(c.deviation), math.degrees(c.max_deviation), spikes,
            max((math.degrees(d) for d in c.spike_departures), default=0.0), item.flips, action.name,
            item.reduced.error_text(settings.tolerance) if item.reduced is not None else "",
            result.length(item.distance) if item.distance is not None else ""))
    result.seconds = time.perf_counter() - begin
    return result


# ---- the distance bound (error='DISTANCE') ------------------------------------------------------------

def bpy_scene():
    import bpy
    return bpy.context.scene


@dataclass(eq=False)
class _Group:
    """One armature (or object) under the distance bound: its skeleton (every bone posed), the items
    of its selected bones by bone index, the bound and shell (scene units), and Blender's float32
    posing slack (reduce.float32_slack), which the measured distance must leave free."""
    read: object                # skeleton.ReadSkeleton
    items: dict                 # bone index -> _Item
    distance: float = 0.0
    shell: float = 0.0
    slack: float = 0.0
    worst: float = 0.0          # the measured worst over every bone and frame that is not a spike
    where: str = ""
    rounds: int = 0


def distance_groups(found, items, settings):
    """The _Groups of the DISTANCE clean: the targets' armatures read as skeletons (objects as their
    own three shell points), as reduce_distance reads them; each item then samples the skeleton's
    frames. Raises CleanError as skeleton.py refuses."""
    from . import skeleton
    scene = bpy_scene()
    _, shell = reduce.scene_lengths(settings, scene)
    by_object = {}
    for target, item in zip(found, items):
        by_object.setdefault(target.object.name_full, (target.object, []))[1].append((target, item))
    groups = []
    try:
        for obj, members in by_object.values():
            bones = [(t, i) for t, i in members if t.bone is not None]
            if bones:
                read = skeleton.read_armature(obj, [t.bone for t, _ in bones])
                index = {name: b for b, name in enumerate(read.names)}
                groups.append(_Group(read, {index[t.bone]: i for t, i in bones}, shell=shell))
            for t, i in members:
                if t.bone is None:
                    groups.append(_Group(skeleton.read_object(obj), {0: i}, shell=shell))
    except TargetError as error:
        raise CleanError(str(error)) from error
    for group in groups:
        for b, item in group.items.items():
            item.read.frames = group.read.frames  # every bone at the skeleton's frames (its playback)
            item.read.values = np.array(group.read.rotations[b][1], dtype=np.float64)
        group.slack = reduce.float32_slack(group.read, shell)
    return groups


def clean_distance(group, work, distance):
    """Cleans the group's bones so that every virtual vertex stays within the bound at every frame
    that is not a spike of its bone or a parent; `work(item)` cleans one item within item.budget.

    Each bone's σ is estimated first; the bound is `distance` (scene units), or with 0 the largest
    DEVIATION_FACTOR·σ·R over the bones (R: the farthest a virtual vertex of the bone or a descendant
    gets from its head, Skeleton.dominant_shell_budgets), at least 4 × the float32 slack. A bone's
    first budget is the bound (less the slack) over its R: its own error alone moves no vertex
    further. Then, round after round: every bone cleaned within its budget, the written values
    (float32) posed against the captured pose (Skeleton.vertex_distances, every bone), the spike
    frames of each bone and its parents left out; where a bone's vertices still exceed the bound,
    the budgets of the selected bones of its chain (it and its parents) shrink by the ratio of
    bound to measured (between ×0.5 and ×0.8), and those bones are cleaned again. Raises CleanError
    when DISTANCE_ROUNDS rounds do not get there."""
    qc = native.require()
    read = group.read
    sk = read.skeleton()
    captured = np.array([qc.channels_to_quats(v, mode) for mode, v in read.rotations])
    motion = (read.locations, captured, read.scales)
    for b, item in group.items.items():
        item.noise = float(qc.estimate_rotation_noise(read.frames, captured[b]))
    pose = sk.pose(*motion)
    # Skeleton.dominant_shell_budgets gives probe / R (π where R = 0): R recovered with a probe far
    # below any length, so that only R = 0 reads π.
    probe = 1e-12
    reach = {b: (0.0 if u >= math.pi else probe / u) for b, u in enumerate(sk.dominant_shell_budgets(pose, probe,
                                                                                                  group.shell))}
    if distance > 0:
        group.distance = distance
    else:
        group.distance = max([DEVIATION_FACTOR * item.noise * reach[b] for b, item in group.items.items()] + [0.0])
        group.distance = max(group.distance, 4 * group.slack)
    if group.slack >= 0.5 * group.distance:
        raise CleanError("%s: a distance of %s is below what Blender's float32 posing keeps at this size (%s)" % (
            read.object.name, reduce.length_text(group.distance), reduce.length_text(2 * group.slack)))
    target = group.distance - group.slack
    for b, u in enumerate(sk.dominant_shell_budgets(pose, target, group.shell)):
        if b in group.items:
            group.items[b].budget = min(math.pi, float(u))
    chains = [[]] * len(read.parents)
    for b, p in enumerate(read.parents):  # parents come first: each chain from the bone up to its root
        chains[b] = [b] + (chains[p] if p >= 0 else [])
    todo = list(group.items.values())
    for group.rounds in range(1, DISTANCE_ROUNDS + 1):
        parallel_map(work, todo)
        cleaned = captured.copy()
        for b, item in group.items.items():
            written = item.values.astype(np.float32).astype(np.float64)  # what the F-curves hold
            cleaned[b] = qc.channels_to_quats(written, read.rotations[b][0])
        distances = sk.vertex_distances(motion, (read.locations, cleaned, read.scales), group.shell)
        spikes = {b: np.asarray(item.cleaned.spike_frames, dtype=int) for b, item in group.items.items()}
        for b, chain in enumerate(chains):
            for a in chain:
                if a in spikes:
                    distances[b, spikes[a]] = 0.0  # a spike frame of the bone or a parent: no bound
        worst = distances.max(axis=1)
        for b, item in group.items.items():
            item.distance = float(worst[b])
        k = int(worst.argmax())
        group.worst = float(worst[k])
        group.where = "%s, frame %s" % (read.targets[k].name, num(read.frames[int(distances[k].argmax())]))
        if group.worst <= target:
            return
        factors = {}
        for b in np.flatnonzero(worst > target):
            factor = min(0.8, max(0.5, target / worst[b]))
            for a in chains[b]:
                if a in group.items:
                    factors[a] = min(factors.get(a, 1.0), factor)
        for a, factor in factors.items():
            group.items[a].budget *= factor
        todo = [group.items[a] for a in sorted(factors)]
    raise CleanError("%s: %d rounds of tighter budgets left a virtual vertex %s from the capture (bound %s) at %s" % (
        read.object.name, DISTANCE_ROUNDS, reduce.length_text(group.worst), reduce.length_text(group.distance),
        group.where))
