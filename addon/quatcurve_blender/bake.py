"""Baking: turn the rotation keys of objects and pose bones into dense LINEAR keys of a chosen method.

Plain functions, no operator state: the `quatcurve.bake` operator, the CLI and scripts call the same
code. Data flows one way: targets.py reads each target's keys → a native curve samples them →
native channel values of the output rotation mode (quatcurve.quats_to_channels) → write.py writes
them (optionally reduced first by reduce.reduce_values).

With error='DISTANCE' the targets are baked dense (every `step` frames), then the written action is
reduced by reduce.reduce(error='DISTANCE') — the reduction the `quatcurve.reduce` operator runs —
so every armature's virtual vertices stay within `distance` of the dense bake's at every frame and
key (objects: their own shell points). A refusal of the reduction after the dense keys are written
removes the new actions again.

    found = targets.gather_targets(bpy.context)        # or [targets.Target(obj), targets.Target(rig, "Bone")]
    result = bake.bake(found, bake.BakeSettings(method="SQUAD", rotation_mode="QUATERNION"))
    print(result.summary())

A loop (cycles.py: every rotation channel a plain Cycles modifier over one period) bakes one period:
the method's closed curve (`cyclic=True`: tangents across the seam) sampled from the first key to
the last, written with a Cycles modifier on the new channels — Repeat, or Repeat with Offset where
the source repeats with offset and the baked Euler angles end whole turns from where they start (a
wheel keeps turning in the graph too). The frame range setting does not apply to a loop.

Everything is read before anything is written (`prepare`), then `BakePlan.write` computes and
writes: into new actions it writes each target while worker threads compute the next ones, and a
BakeError on the way removes the new actions again; in place it computes everything first. Either
way a BakeError or a cancelled bake leaves the file untouched.
"""

import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import cycles, fcurves, fit, methods, native, path_rule, reduce, targets, write
from .workers import parallel_imap, parallel_map, thread_count
from .reduce import reduce_values as reduce_keys
from .targets import TargetError, num

METHODS = methods.ALL
OUTPUT_MODES = ("QUATERNION",) + fcurves.EULER_ORDERS + ("AXIS_ANGLE", "KEEP")
MAX_FRAMES = 10_000_000  # longest frame range a bake accepts (checked before allocating)


class BakeError(TargetError):
    """A bake that cannot be done; the message names the object, bone, channel and frame at fault.
    Raised before anything is written."""


# ---- settings ---------------------------------------------------------------------------------------

@dataclass
class BakeSettings:
    """What to bake. Angles in the UI are degrees; `tolerance` is in degrees too (it is a UI value)."""
    method: str = "SLERP"
    rotation_mode: str = "KEEP"       # output mode: QUATERNION, an Euler order, AXIS_ANGLE or KEEP
    frame_start: float = None         # None: the keyed range of the targets (default_frame_range)
    frame_end: float = None
    step: float = 1.0                 # frames between baked keys (≥ 1)
    tolerance: float = 0.0            # degrees; > 0 asks for key reduction (reduce.reduce_values)
    new_action: bool = True           # bake into a copy of each action; False: replace in place
    tension: float = 0.0              # TCB
    continuity: float = 0.0           # TCB
    bias: float = 0.0                 # TCB
    shortest_path: bool = True        # SLERP
    clamped: bool = True              # SQUAD, TCB, CATMULL_ROM: overshoot-free tangents (False: textbook)
    error: str = "ANGLE"              # DISTANCE: baked dense, then reduced as reduce(error='DISTANCE')
    distance: float = 0.0             # DISTANCE: scene units (0: 1 mm in real size), as ReduceSettings
    shell: float = 0.0                # DISTANCE: scene units (0: 10 cm in real size)

    def curve_options(self):
        """Keyword options of quatcurve.Curve for this method (only the ones it accepts)."""
        return methods.options(self.method, self)


def check_settings(settings):
    """Raises BakeError for settings no bake can use (before any data is looked at)."""
    if settings.method not in METHODS:
        raise BakeError("method %r: unknown (expected one of %s)" % (settings.method, ", ".join(METHODS)))
    if settings.rotation_mode not in OUTPUT_MODES:
        raise BakeError("rotation mode %r: unknown (expected one of %s)"
                        % (settings.rotation_mode, ", ".join(OUTPUT_MODES)))
    if not (settings.step >= 1):  # also refuses NaN
        raise BakeError("step %s: must be at least 1 frame" % num(settings.step))
    if not (settings.tolerance >= 0):
        raise BakeError("tolerance %s°: must be 0 or more" % num(settings.tolerance))
    if settings.error not in reduce.ERRORS:
        raise BakeError("error %r: unknown (expected ANGLE or DISTANCE)" % (settings.error,))
    if settings.error == "DISTANCE":
        if settings.tolerance != 0:
            raise BakeError("tolerance %s°: the distance bound is the reduction's bound (give tolerance 0 with "
                            "error DISTANCE)" % num(settings.tolerance))
        if not settings.new_action:
            raise BakeError("error DISTANCE bakes into a new action (its dense keys are written, then reduced; a "
                            "refusal of the reduction removes them again): turn New Action on")
    try:
        reduce.check_settings(distance_settings(settings))
    except reduce.ReduceError as error:
        raise BakeError(str(error)) from None


def distance_settings(settings):
    """The ReduceSettings of a bake's reduction under the distance bound (error='DISTANCE'): in place
    on the action the bake wrote, BEZIER keys per channel."""
    return reduce.ReduceSettings(error="DISTANCE", distance=settings.distance, shell=settings.shell,
                                 new_action=False)


def bake_frames(frame_start, frame_end, step):
    """The frames that get a key: frame_start, +step, … and frame_end itself (always keyed; native
    quatcurve.step_frames). Raises BakeError for an empty range, step < 1, or more than MAX_FRAMES
    frames — before allocating anything."""
    if not (step >= 1):
        raise BakeError("step %s: must be at least 1 frame" % num(step))
    if not (math.isfinite(frame_start) and math.isfinite(frame_end)):
        raise BakeError("frame range %s..%s: not finite" % (num(frame_start), num(frame_end)))
    if frame_end < frame_start:
        raise BakeError("frame range %s..%s is empty" % (num(frame_start), num(frame_end)))
    if frame_end - frame_start > MAX_FRAMES:
        raise BakeError("frame range %s..%s is %s frames long: at most %s frames can be baked"
                        % (num(frame_start), num(frame_end), num(frame_end - frame_start), f"{MAX_FRAMES:,}"))
    return native.require().step_frames(frame_start, frame_end, step)


def output_values(quats, mode, reference=None):
    """(N, 3|4) channel values of `mode` for sampled quats, continuous along the samples (native
    quatcurve.quats_to_channels, Euler branch 'continuous').

    reference, when the target's source keys are already in `mode`: for QUATERNION and AXIS_ANGLE
    the source's channel values at the first frame (the first sample takes the representation
    closest to it); for an Euler order an (N, 3) path of the source's angles at every sample, which
    each sample's Euler solution is chosen closest to (so the baked angles keep the keyed turn counts)."""
    return native.require().quats_to_channels(quats, mode, reference)


# ---- plan, compute, write -------------------------------------------------------------------------------

@dataclass(eq=False)
class TargetBake:
    """One target's bake, computed but not yet written."""
    target: targets.Target
    source: targets.RotationKeys
    output_mode: str
    frames: np.ndarray = None
    values: np.ndarray = None    # (N, 3|4) output channel values (for the reduction, tolerance > 0)
    packed: list = None          # per channel fcurves.PackedKeys of the dense keys (no reduction)
    own_action: bool = False     # in place was asked for, but others play the action: copy it
    reduced: object = None       # reduce_keys' result when tolerance > 0
    notes: list = field(default_factory=list)
    loop: cycles.Loop = None     # the source's loop: one period baked, a Cycles modifier written


@dataclass
class TargetResult:
    name: str
    source_mode: str
    output_mode: str
    source_keys: int
    keys_written: int
    action: str
    notes: list = field(default_factory=list)
    max_error_deg: float = None  # the key reduction's bound (tolerance > 0; at every instant), else None


@dataclass
class BakeResult:
    method: str
    frame_start: float
    frame_end: float
    targets: list = field(default_factory=list)
    keys_written: int = 0
    seconds: float = 0.0
    reduction: object = None     # error='DISTANCE': the reduce.ReduceResult of the dense bake's reduction

    def summary(self):
        text = "%d target%s, %s keys" % (len(self.targets), "" if len(self.targets) == 1 else "s",
                                         f"{self.keys_written:,}")
        r = self.reduction
        if r is not None:
            text += ", worst distance %s (bound %s, shell %s) at every frame and key of the dense bake" % (
                r.length(r.worst_distance), r.length(r.distance), r.length(r.shell))
        return text + ", %.2f s" % self.seconds

    @property
    def worst_distance(self):
        """error='DISTANCE': the worst virtual-vertex distance (scene units), else None."""
        return None if self.reduction is None else self.reduction.worst_distance

    def lines(self):
        """One line per target, each followed by its notes (held channels, modifiers, NLA, …)."""
        out = []
        for t in self.targets:
            out.append("%s: %s, %s → %s, %d source keys → %s keys in '%s'"
                       % (t.name, methods.label(self.method), t.source_mode, t.output_mode, t.source_keys,
                          f"{t.keys_written:,}", t.action))
            out.extend(t.notes)
        if self.reduction is not None:
            out.extend("reduced: " + line for line in self.reduction.lines())
        return out

    def notes(self):
        return [note for t in self.targets for note in t.notes]


class BakePlan:
    """A validated bake: sources read, frames chosen. `compute_steps()` (or `compute()`) samples the
    curves target by target without touching Blender data; `write()` computes what is left and writes
    everything. Drop the plan to cancel: nothing has changed until write()."""

    def __init__(self, found, settings, sources, frames, seconds, loops=None):
        self.settings = settings
        self.frames = frames
        self.items = [TargetBake(t, s, s.mode if settings.rotation_mode == "KEEP" else settings.rotation_mode,
                                 loop=loop)
                      for t, s, loop in zip(found, sources, loops or [None] * len(found))]
        for item in self.items:
            if item.loop is not None:
                item.frames = bake_frames(item.loop.start, item.loop.end, settings.step)
                item.notes.append("%s: a loop (Cycles modifier): one period baked, frames %s–%s, and a Cycles "
                                  "modifier on the baked channels" % (item.target.name, num(item.loop.start),
                                                                     num(item.loop.end)))
        self.seconds = seconds   # working time so far (a modal bake's idle time is not counted)
        self.increasing = bool(len(frames) < 2 or (frames[1:] > frames[:-1]).all())
        self.computed = 0

    def compute_steps(self):
        """Computes one target per step; yields the fraction done after each."""
        while self.computed < len(self.items):
            begin = time.perf_counter()
            self._compute(self.items[self.computed])
            self.computed += 1
            self.seconds += time.perf_counter() - begin
            yield self.computed / len(self.items)

    def compute(self):
        """Computes every target left: Blender's data read here, on the main thread, then the native
        work (curve, sampling, channels, reduction) on worker threads; the results do not depend on
        the thread count."""
        begin = time.perf_counter()
        todo = self.items[self.computed:]
        if self.settings.tolerance == 0:
            threads = thread_count()
            for _ in self._dense(todo, threads if threads > 1 else 0):
                pass
        else:
            references = [self._reference(item) for item in todo]
            parallel_map(lambda job: self._reduced(*job), list(zip(todo, references)))
        self.computed = len(self.items)
        self.seconds += time.perf_counter() - begin
        return self

    def _compute(self, item):
        if self.settings.tolerance == 0:
            for _ in self._dense([item], 0):
                pass
        else:
            self._reduced(item, self._reference(item))

    def _frames_of(self, item):
        """The frames `item` is baked at: its loop's period, or the plan's frames."""
        return item.frames if item.loop is not None else self.frames

    def _options(self, item):
        """The curve's options for `item`: the settings', and cyclic for a loop."""
        options = self.settings.curve_options()
        if item.loop is not None:
            options["cyclic"] = True
        return options

    def _reference(self, item):
        """What output_values needs from Blender for `item` (read on the main thread), or None."""
        source, frames = item.source, self._frames_of(item)
        if source.mode == item.output_mode and source.is_euler:
            # The keyed angles, linear between keys: a cheap guide to the branch, not output math.
            return np.column_stack([np.interp(frames, source.frames, source.values[:, i])
                                    for i in range(3)])
        if source.mode == item.output_mode:
            if len(source.frames) and frames[0] == source.frames[0]:
                return source.values[0].copy()  # read there already (the same evaluation)
            return targets.playback(item.target).evaluate(frames[:1])[0]
        return None

    def _dense(self, todo, threads):
        """Yields each item of `todo` in order once its dense keys are computed (item.packed, its
        path-rule notes). A quatcurve.BakeQueue computes them on `threads` native worker threads (0:
        each here, when it is asked for). The workers never need the GIL, so the caller may write
        keys between the items without waiting for them, or they for it (Python worker threads wait
        for the GIL at every step between two native calls). Blender is read here, on the calling
        thread, before any job starts."""
        settings = self.settings
        jobs = []
        for item in todo:
            try:
                jobs.append(item.source.bake_job(settings.method, item.output_mode, self._reference(item),
                                                 **self._options(item)))
            except ValueError as error:
                raise BakeError("%s: %s" % (item.target.name, error)) from error
        qc = native.require()
        # Open targets share the plan's frames (one queue); a loop is sampled over its own period.
        queue = qc.BakeQueue(self.frames, [j for i, j in zip(todo, jobs) if i.loop is None], threads=threads)
        for item, job in zip(todo, jobs):
            try:
                if item.loop is None:
                    keys, broken = next(queue)
                else:
                    keys, broken = next(qc.BakeQueue(item.frames, [job], threads=0))
            except ValueError as error:
                raise BakeError("%s: %s" % (item.target.name, error)) from error
            item.notes += ["path rule: " + b.text() for b in path_rule.breaks(
                None, item.source.frames, item.target.name, settings.method, rows=broken)]
            item.frames = self._frames_of(item)
            item.packed = [fcurves.PackedKeys.from_pairs(rows, self.increasing) for rows in keys]
            yield item

    def _reduced(self, item, reference):
        """The curve through the item's keys, sampled, as output channel values, reduced (tolerance
        > 0): no Blender data is touched, so it may run on a worker thread."""
        settings, source = self.settings, item.source
        try:
            curve = source.curve(settings.method, **self._options(item))
            broken = path_rule.breaks(curve, source.frames, item.target.name, settings.method)
        except ValueError as error:
            raise BakeError("%s: %s" % (item.target.name, error)) from error
        item.notes += ["path rule: " + b.text() for b in broken]
        item.frames = self._frames_of(item)
        quats = np.asarray(curve.sample(item.frames), dtype=np.float64)
        item.values = output_values(quats, item.output_mode, reference)
        if not np.isfinite(item.values).all():
            raise BakeError("%s: the %s curve gave non-finite values"
                            % (item.target.name, methods.label(settings.method)))
        try:
            # Proved against the curve at every instant, not only at the baked frames.
            item.reduced = reduce_keys(item.frames, item.values, item.output_mode,
                                       math.radians(settings.tolerance), curve=curve,
                                       one_key=item.loop is None)  # a loop's Cycles repeat each key range
        except ValueError as error:
            raise BakeError("%s: key reduction: %s" % (item.target.name, error)) from error
        item.notes.append("%s: reduced to %s keys within %s° (%s)" % (
            item.target.name, f"{item.reduced.key_count:,}", num(settings.tolerance),
            item.reduced.error_text(settings.tolerance)))

    def write(self):
        """Writes every target (write.write_rotations), computing first what is not computed yet;
        returns the BakeResult. Into new actions, the targets left are computed on worker threads
        while the main thread writes the ones done (in order); a failure then removes the new
        actions again, so the file is untouched either way. In place, everything is computed before
        anything is written."""
        begin = time.perf_counter()
        settings = self.settings
        todo = self.items[self.computed:]
        computing = None
        if todo and settings.new_action:
            if settings.tolerance == 0:
                # The main thread writes keys meanwhile: it keeps a core for that.
                computing = self._dense(todo, thread_count() - 1)
            else:
                references = [self._reference(item) for item in todo]  # Blender data: main thread

                def reduced(job):
                    self._reduced(*job)
                    return job[0]

                computing = parallel_imap(reduced, list(zip(todo, references)))
            items = itertools.chain(self.items[:self.computed], computing)
        else:
            if todo:
                self.compute()
            items = self.items
        writes = (self._write_of(item) for item in items)
        if not settings.new_action:
            writes = list(writes)
        before = _assignments(self.items)
        try:
            actions = write.write_rotations(writes, settings.new_action, settings.method.lower())
        finally:
            if computing is not None:
                computing.close()  # a failure: stop the workers now, not when the generator is collected
        self.computed = len(self.items)
        result = BakeResult(settings.method, float(self.frames[0]), float(self.frames[-1]))
        if settings.error == "DISTANCE":
            result.reduction = self._reduce_distance(before, actions)
        for item, action in zip(self.items, actions):
            count = self._write_of(item).key_count if result.reduction is None else _rotation_keys(item)
            result.keys_written += count
            result.targets.append(TargetResult(item.target.name, item.source.mode, item.output_mode,
                                               len(item.source.frames), count, action.name,
                                               item.source.notes + item.notes,
                                               None if item.reduced is None else self._reduced_error_deg(item)))
        self.seconds += time.perf_counter() - begin
        result.seconds = self.seconds
        return result

    def _reduce_distance(self, before, actions):
        """error='DISTANCE': the actions just written (the dense bake) reduced in place by
        reduce.reduce(error='DISTANCE'), against the dense keys at every frame and key. A ReduceError
        puts the original actions and rotation modes back, removes the new actions and becomes a
        BakeError: the file is as it was."""
        try:
            return reduce.reduce([item.target for item in self.items], distance_settings(self.settings))
        except BaseException as error:
            for id_data, action, fake_user, owners in before.values():
                if action is not None:
                    fcurves.assign_action(id_data, action)
                    action.use_fake_user = fake_user
                for target, mode in owners:
                    target.owner.rotation_mode = mode
            for action in {a.name_full: a for a in actions}.values():
                fcurves.remove_action(action)
            if isinstance(error, TargetError):
                raise BakeError("distance bound: %s" % error) from None
            raise

    @staticmethod
    def _reduced_error_deg(item):
        """The reduction's bound in degrees: proved at every instant where it was, else at the frames."""
        bound = item.reduced.bound
        return math.degrees(item.reduced.max_error if bound is None else bound)

    @staticmethod
    def _write_of(item):
        if item.reduced is not None:
            keys, interpolation = item.reduced.keys, item.reduced.interpolation
        else:
            keys, interpolation = item.packed, "LINEAR"
        return write.RotationWrite(item.target, item.output_mode, keys, interpolation, own_action=item.own_action,
                                   cycles=BakePlan._cycle_modes(item))

    @staticmethod
    def _cycle_modes(item):
        """The Cycles modifier's (mode_before, mode_after) for a loop's baked channels (None: open):
        Repeat with Offset where the source repeats with offset and every baked Euler angle ends a
        whole number of turns from its start (a wheel); Repeat otherwise — Blender plays each period
        from its own keys, so the rotation is the same either way."""
        if item.loop is None:
            return None
        if item.loop.offset and item.output_mode in fcurves.EULER_ORDERS:
            if item.values is not None:
                first, last = item.values[0], item.values[-1]
            else:  # packed (frame, value) pairs: the first key's value is co[1], the last's co[-1]
                first = np.array([float(k.co[1]) for k in item.packed])
                last = np.array([float(k.co[-1]) for k in item.packed])
            turns = (last - first) / (2 * math.pi)
            if np.all(np.abs(turns - np.round(turns)) < 1e-4) and np.any(np.round(turns) != 0):
                return ("REPEAT_OFFSET", "REPEAT_OFFSET")
        return ("REPEAT", "REPEAT")


def _assignments(items):
    """{ID name: [ID, its action, the action's fake user, [(target, its rotation mode)]]} before a
    write, to put back (error='DISTANCE', a refused reduction)."""
    out = {}
    for item in items:
        id_data = item.target.id_data
        if id_data.name_full not in out:
            action = fcurves.active_action(id_data)
            out[id_data.name_full] = [id_data, action, action.use_fake_user if action is not None else False, []]
        out[id_data.name_full][3].append((item.target, item.target.owner.rotation_mode))
    return out


def _rotation_keys(item):
    """The keys on the target's rotation channels of its output mode, as written now."""
    prop, count = fcurves.rotation_property(item.output_mode)
    channels = fcurves.Channels.of(item.target.id_data)
    return sum(fcurves.key_count(f) for f in channels.find_all(item.target.data_path(prop), count) if f is not None)


def _check_distance(found, loops):
    """error='DISTANCE': refuses, before anything is written, what the reduction of the baked
    action would refuse (skeleton.py: NLA, drivers, constraints, modifiers besides the baked
    rotation channels, inherit scale, …) and loops (the bake writes Cycles modifiers, which the
    distance bound does not model)."""
    from . import skeleton
    for target, loop in zip(found, loops):
        if loop is not None:
            raise BakeError("%s: a loop (Cycles modifier) is baked as one period with a Cycles modifier, which the "
                            "distance bound does not model (bake with error ANGLE)" % target.name)
    groups = {}
    for target in found:
        groups.setdefault(target.object.name_full, (target.object, []))[1].append(target)
    for obj, group in groups.values():
        bones = [t.bone for t in group if t.bone is not None]
        if bones:
            skeleton.check_armature(obj, bones)
        if any(t.bone is None for t in group):
            skeleton.check_object(obj)


def prepare(found, settings):
    """Checks settings and targets (targets.Target) and reads every source; returns a BakePlan
    (nothing written). Raises BakeError naming what is wrong."""
    begin = time.perf_counter()
    check_settings(settings)
    if not found:
        raise BakeError("Nothing to bake: no targets")
    try:
        for target in found:
            targets.check_editable(target, settings.new_action)
        with fcurves.read_cache():
            sources = [fit.source_keys(t) for t in found]
        if settings.method == "EULER":
            for target, source in zip(found, sources):
                if not source.is_euler:
                    raise BakeError("%s: method %s interpolates Euler angle keys, and its keys are %s (bake it with "
                                    "another method, or convert its keys to an Euler order first)"
                                    % (target.name, methods.label("EULER"), source.mode))
        loops = [cycles.loop_of_keys(t, s) for t, s in zip(found, sources)]
        if settings.rotation_mode != "KEEP":
            for target in found:
                targets.refuse_drivers(target, *fcurves.rotation_property(settings.rotation_mode))
        if settings.error == "DISTANCE":
            _check_distance(found, loops)
    except TargetError as error:
        raise BakeError(str(error)) from None
    start, end = settings.frame_start, settings.frame_end
    if start is None:
        start = math.floor(min(s.frames[0] for s in sources))
    if end is None:
        end = math.ceil(max(s.frames[-1] for s in sources))
    frames = bake_frames(start, end, settings.step)
    plan = BakePlan(found, settings, sources, frames, time.perf_counter() - begin, loops)
    if not settings.new_action:
        _keep_shared_actions(plan)
    return plan


def _keep_shared_actions(plan):
    """In place was asked for, but an action a target plays is also played by objects that are not
    being baked: changing it would silently change them, so those targets get their own new action
    instead, and the report says so."""
    ids = {item.target.id_data.name_full for item in plan.items}
    for item in plan.items:
        others = write.shared_with(item.target, ids)
        if others:
            item.own_action = True
            item.notes.append("%s: action '%s' is also used by %s: baked into a new action instead of in "
                              "place, so %s keep%s playing it" % (
                                  item.target.name, fcurves.active_action(item.target.id_data).name,
                                  ", ".join(others), "they" if len(others) > 1 else "it",
                                  "" if len(others) > 1 else "s"))


def bake(found, settings):
    """Bakes `found` (targets.Target) with `settings` synchronously; returns the BakeResult. On
    BakeError nothing has been changed."""
    return prepare(found, settings).write()
