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
range and at every key frame. Quaternion samples are reduced hemisphere-continuous (signs flipped
where neighbours disagree: the same rotations, and no forced keys at the flips).

The bound at every instant: when Blender's playback of the original keys can be emulated (every
segment of the rotation channels LINEAR, or every one BEZIER; no NLA strips playing; constant
extrapolation where a channel's keys end early), the native `quatcurve.reduce_keys_proved` reduces
against that playback and proves the reduced keys within the tolerance of it at every instant from
the first key to the last, not only at frames. Where the original's own quaternion keys flip sign
(two neighbouring samples, or the two keys of a segment, in opposite hemispheres), Blender
interpolates the four channels through near zero — a turn of up to 360° inside that segment — and
the reduced keys play it exactly as the original does: they are the original's keys there, copied bit
for bit (from the last frame before the flip where every channel has a key to the first after it:
frames, values with their stored signs, the handles of those segments, the original's
interpolation; FREE handles, so Blender keeps them), which is why they are within the bound there.
The pieces between are reduced as above, each in the hemisphere of its own stored signs, ending on
the copied keys (`TargetResult.copied` lists the spans). Where a reduction stays unproved after
all its rounds (keys a few hundredths of a frame apart), the original's keys are copied there too,
in spans that grow until the pieces between are proved; where it would keep more keys than the
original has, or the pieces stay unproved, the original's keys stay, copied whole (the result line
says so). Where the playback cannot be emulated, the reduction holds at frames and keys
(`reduce_values`) and the result line says why between frames is not proved.
Rotation modes: quaternion, the six Euler orders and axis-angle (the bound is on the rotation Blender
builds; axis-angle channels are kept as Blender evaluates them, a zero axis is refused). F-curves
with modifiers are refused (the bound is for the keys alone), except a loop's (cycles.py): its period
is reduced, from its first key to its last (both kept), and the reduced channels get the original's
Cycles modifiers back. Blender repeats the reduced period as it repeats the original one, so the
bound proved over one period holds in every period, across the seam too.
Everything is read and computed before anything is written, so an error leaves the file untouched.

The bake calls `reduce_values` (imported by bake.py) with its method's curve when its tolerance is
above 0, so `quatcurve.bake` with tolerance > 0 writes BEZIER keys, per channel where that saves keys,
proved within the tolerance of the curve at every instant (`quatcurve.reduce_curve_proved`).
"""

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import cycles, fcurves, native, targets, write
from .workers import parallel_imap
from .targets import TargetError, num

INTERPOLATIONS = ("LINEAR", "BEZIER")
ERRORS = ("ANGLE", "DISTANCE")
DEFAULT_DISTANCE, DEFAULT_SHELL = 0.001, 0.1  # metres in real size: 1 mm at a 10 cm shell (ozz's default)


class ReduceError(TargetError, ValueError):
    """A reduction that cannot be done; the message names the target and what is wrong. Raised
    before anything is written. A ValueError too, as the bake expects of its reduction."""


@dataclass
class ReduceSettings:
    """tolerance in degrees (a UI value; the native reducer takes radians). interpolation: the key
    interpolation written ('BEZIER' keeps far fewer keys; its handles are FREE and broken at keys).
    synchronized: the same key frames on every channel of a target (for glTF export and hand
    editing); off lets each channel keep its own keys where that saves keys. new_action: write into
    a copy of each action (the original is kept with a fake user); off: replace in place.

    error: 'ANGLE' (the default: every target's rotation within `tolerance`, target by target) or
    'DISTANCE' (per armature, every virtual vertex within `distance` in object space: reduce.py's
    reduce_distance). distance, shell: scene units (Blender units, before the unit scale); 0 takes
    1 mm and 10 cm in real size (scene.unit_settings.scale_length taken into account)."""
    tolerance: float = 0.1
    interpolation: str = "BEZIER"
    synchronized: bool = False
    new_action: bool = True
    error: str = "ANGLE"
    distance: float = 0.0
    shell: float = 0.0


def check_settings(settings):
    if not (settings.tolerance >= 0) or not math.isfinite(settings.tolerance):
        raise ReduceError("tolerance %r°: must be a finite angle of 0 or more" % (settings.tolerance,))
    if settings.interpolation not in INTERPOLATIONS:
        raise ReduceError("interpolation %r: unknown (expected LINEAR or BEZIER)" % (settings.interpolation,))
    if settings.error not in ERRORS:
        raise ReduceError("error %r: unknown (expected ANGLE or DISTANCE)" % (settings.error,))
    for name in ("distance", "shell"):
        value = getattr(settings, name)
        if not (value >= 0) or not math.isfinite(value):
            raise ReduceError("%s %r: must be a finite length of 0 or more (0: the default)" % (name, value))


# ---- the native call ------------------------------------------------------------------------------

@dataclass
class ReducedChannels:
    """Reduced keys of one target's rotation channels. keys[i] = (frames, values, handle_left,
    handle_right) of channel i (handles (K, 2) where a key has a BEZIER segment, None otherwise);
    max_error in radians (Blender's evaluation, emulated, against the samples).

    proof: the quatcurve.PlaybackBound of Blender's playback of the keys against the reference (the
    original keys' playback, or the bake's curve) at every instant from the first sample to the last
    — None when nothing was proved between frames (`between` then says why). copied: (M, 2) frame
    spans [f0, f1] whose keys are the original's own, bit for bit, around its quaternion sign flips
    (their segments keep the original's interpolation, `copied_interpolation`: key_interpolations)."""
    interpolation: str
    keys: list
    max_error: float
    proof: object = None
    copied: np.ndarray = None
    copied_interpolation: str = ""
    between: str = ""

    @property
    def key_count(self):
        return sum(len(k[0]) for k in self.keys)

    @property
    def bound(self):
        """Radians: Blender's playback stays within it at every instant, or None."""
        return None if self.proof is None else self.proof.bound

    @property
    def key_interpolations(self):
        """Per channel, each key's interpolation (the segment after it): the original's for a key in a
        copied span [f0, f1) — and for the channel's last key when a span ends there (no segment
        follows it: the original's keys stay as they were) —, `interpolation` for the others; or None
        when every key has `interpolation`."""
        if self.copied is None or not len(self.copied) or self.copied_interpolation == self.interpolation:
            return None
        out = []
        for frames, *_ in self.keys:
            frames = np.asarray(frames)
            inside = np.zeros(len(frames), dtype=bool)
            for f0, f1 in self.copied:
                inside |= (frames >= f0) & (frames < f1)
                if len(frames) and frames[-1] == f1:
                    inside[-1] = True
            out.append(np.where(inside, self.copied_interpolation, self.interpolation))
        return out

    def kept_original(self, frames):
        """True when the result is the original's own keys over the whole range (one copied span from
        the first frame to the last): the reduction would have kept more keys."""
        copied = self.copied
        return (copied is not None and len(copied) == 1 and float(copied[0][0]) <= np.float32(frames[0])
                and float(copied[0][1]) >= np.float32(frames[-1]))

    def error_text(self, tolerance_deg):
        """The error for a result line: 'max error X° at every instant' (the proved bound), or where
        the proof did not get within the tolerance the bound, what it found and where. Without a
        proof: 'max error X° at frames and keys (between frames not proved: why)'."""
        if self.proof is None:
            return "max error %.4f° at frames and keys (between frames not proved: %s)" % (
                math.degrees(self.max_error), self.between)
        proof = self.proof
        bound = math.degrees(proof.bound)
        text = "max error %.4f° at every instant" % bound
        if not proof.proven and len(proof.violations):
            text += " — ABOVE the tolerance: %.4f° found, near frame %s" % (
                math.degrees(proof.max_evaluated), num(proof.worst_time))
        elif not proof.proven:
            text = ("max error %.4f° at frames and keys; between frames within the tolerance except near "
                    "frame %s, where it is not proved (bounded by %.4f°)" % (
                        math.degrees(self.max_error), num(proof.worst_time), bound))
        return text


def _channels_of(result):
    """(frames, values, handle_left, handle_right) per channel; handles None where the keys have none."""
    return [(ch.frames, ch.values, *((ch.handle_left, ch.handle_right) if len(ch.handle_left) else (None, None)))
            for ch in result.channels]


def _proved(proved, interpolation):
    """ReducedChannels of a quatcurve.ProvedKeys (tolerance 0 proves nothing between samples)."""
    proof = proved.proof if math.isfinite(proved.proof.bound) else None
    return ReducedChannels(interpolation, _channels_of(proved.keys), proved.keys.max_error, proof=proof,
                           copied=proved.copied, copied_interpolation=proved.copied_interpolation,
                           between="" if proof is not None else "a tolerance of 0 keeps every sample")


def reduce_values(frames, values, mode, tolerance_rad, interpolation="BEZIER", synchronized=False, curve=None,
                  original=None, one_key=True):
    """Reduces dense channel values (N, 4) of mode 'QUATERNION' or 'AXIS_ANGLE' (angle, x, y, z) or
    (N, 3) of an Euler order, sampled at `frames`, to ReducedChannels. Quaternions are made
    hemisphere-continuous first; Euler and axis-angle values are kept as given. Raises ReduceError
    for other modes or input the native reducer refuses.

    curve: the quatcurve.Curve the values sample (the bake): the reduction is proved against it at
    every instant (quatcurve.reduce_curve_proved). original: (channels, interpolation) of the keys the
    values are Blender's evaluation of (read_original): proved against their playback
    (quatcurve.reduce_keys_proved). Neither: proved at the samples only. one_key (with curve or
    original): a channel one value meets keeps one key (False for a loop's period)."""
    qc = native.require()
    frames = np.asarray(frames, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    if mode not in ("QUATERNION", "AXIS_ANGLE") + fcurves.EULER_ORDERS:
        raise ReduceError("rotation mode %s: key reduction handles quaternion, Euler and axis-angle "
                          "rotations" % mode)
    if curve is not None or original is not None:
        try:
            if curve is not None:
                proved = qc.reduce_curve_proved(curve, mode, frames, values, tolerance_rad, interpolation,
                                                synchronized, one_key_channels=one_key)
            else:
                proved = qc.reduce_keys_proved(original[0], original[1], mode, frames, values, tolerance_rad,
                                               interpolation, synchronized, one_key_channels=one_key)
        except ValueError as error:
            raise ReduceError(str(error)) from error
        return _proved(proved, interpolation)
    try:
        if mode == "QUATERNION":
            values = qc.quats_to_channels(values, "QUATERNION")
            result = qc.reduce_keys(frames, values, tolerance_rad, interpolation, synchronized,
                                    detailed=True)
        elif mode in fcurves.EULER_ORDERS:
            result = qc.reduce_keys_euler(frames, values, mode, tolerance_rad, interpolation,
                                          synchronized, detailed=True)
        else:
            result = qc.reduce_keys_axis_angle(frames, values, tolerance_rad, interpolation,
                                               synchronized, detailed=True)
    except ValueError as error:
        raise ReduceError(str(error)) from error
    return ReducedChannels(interpolation, _channels_of(result), result.max_error)


# ---- the original keys' playback, for the proof ------------------------------------------------------

EMULATED = ("LINEAR", "BEZIER")  # interpolations quatcurve.blender_evaluate plays as Blender does


def read_original(playback, frames):
    """(channels, interpolation) of the original keys behind `playback` (targets.Playback), as
    quatcurve.reduce_keys_proved takes them — each channel (frames, values, handle_left,
    handle_right), an unkeyed channel as one key holding the property's value — or (None, why) when
    Blender's playback of them is not emulated bit for bit: NLA strips, another interpolation than
    LINEAR or BEZIER, LINEAR and BEZIER segments mixed, keys out of order, or linear extrapolation
    where a channel's keys end before the others'. (Easing shapes only Blender's dynamic-effect
    interpolations, never LINEAR or BEZIER ones; modifiers are refused before this is read.)"""
    if playback.nla:
        return None, "NLA strips play on it"
    kinds = set()
    for index, fcurve in enumerate(playback.fcurves):
        if fcurve is None:
            continue
        found = fcurves.segment_interpolations(fcurve)
        odd = sorted(found - set(EMULATED))
        if odd:
            return None, "%s[%d] has %s keys" % (playback.prop, index, "/".join(odd))
        kinds |= found
    if len(kinds) > 1:
        return None, "its rotation channels mix LINEAR and BEZIER keys"
    interpolation = kinds.pop() if kinds else "LINEAR"
    current = getattr(playback.target.owner, playback.prop)
    channels = []
    for index, fcurve in enumerate(playback.fcurves):
        if fcurve is None:
            value = float(current[index])
            point = np.array([[frames[0], value]])
            channels.append((frames[:1].copy(), np.array([value]), point, point))
            continue
        key_f, key_v = fcurves.read_keys(fcurve)
        if len(key_f) > 1 and not (key_f[1:] > key_f[:-1]).all():
            return None, "%s[%d]'s keys are not in frame order" % (playback.prop, index)
        if fcurve.extrapolation != "CONSTANT" and (key_f[0] > frames[0] or key_f[-1] < frames[-1]):
            return None, "%s[%d] extrapolates linearly" % (playback.prop, index)
        left, right = fcurves.read_handles(fcurve)
        channels.append((np.array(key_f), np.array(key_v), left, right))
    return (channels, interpolation), ""


# ---- reducing existing keys (the operator) ----------------------------------------------------------

@dataclass(eq=False)
class TargetReduce:
    target: targets.Target
    mode: str
    prop: str
    frames: np.ndarray          # sample frames
    values: np.ndarray          # (N, C) Blender's evaluation of the channels there
    keys_before: int
    original: tuple = None      # read_original's (channels, interpolation); None: not emulated
    between: str = ""           # why nothing is proved between frames (original is None)
    reduced: ReducedChannels = None
    loop: cycles.Loop = None    # a loop: its period is reduced
    cycles: tuple = None        # per channel, the Cycles modifier's (mode_before, mode_after) to put back

    @property
    def untouched(self):
        """The reduction keeps more keys than the target has, and its playback could not be
        emulated (CONSTANT keys, mixed interpolations: the native copy of the original's keys needs
        the emulation): its F-curves are left as they are, which play as they did."""
        return self.original is None and self.reduced.key_count > self.keys_before


@dataclass
class TargetResult:
    name: str
    mode: str
    keys_before: int
    keys_after: int
    max_error_deg: float        # at the samples (every frame and key), Blender's evaluation emulated
    action: str
    error_text: str = ""        # ReducedChannels.error_text: the bound at every instant, or why not
    bound_deg: float = None     # at every instant; None: no proof ran
    proven: bool = False        # bound_deg is within the tolerance
    copied: list = field(default_factory=list)  # (start, end) frames whose keys are the original's (sign flips, unproved)


@dataclass
class SkeletonResult:
    """One armature (or object) reduced under the distance bound: the worst virtual-vertex distance
    in its object space (scene units), where it is (bone, frame, vertex), the rotation keys before and
    after over its reduced bones, and the action written."""
    name: str
    bones: int                  # bones reduced
    keys_before: int
    keys_after: int
    worst: float                # scene units, verified: Blender's float32 evaluation of the keys, posed
    bone: str
    frame: float
    vertex: str                 # 'tail', 'shell X', 'shell Y', 'shell Z'
    action: str
    worst_text: str = ""        # worst, with the scene's units
    kept: tuple = ()            # bones asked for whose reduction needed more keys: their keys stay


@dataclass
class ReduceResult:
    tolerance: float
    interpolation: str
    targets: list = field(default_factory=list)
    keys_before: int = 0
    keys_after: int = 0
    max_error_deg: float = 0.0
    seconds: float = 0.0
    error: str = "ANGLE"
    distance: float = None      # DISTANCE: the bound and the shell (scene units), the worst distance
    shell: float = None
    worst_distance: float = 0.0
    units: tuple = None         # (system, scale_length) for length_text

    def summary(self):
        if self.error == "DISTANCE":
            share = 100.0 * self.keys_after / self.keys_before if self.keys_before else 0.0
            return ("%d armature%s/object%s, rotation keys %s → %s (%.1f %%), worst distance %s (bound %s, shell %s) "
                    "at every frame and original key, %.2f s"
                    % (len(self.targets), "" if len(self.targets) == 1 else "s", "" if len(self.targets) == 1 else "s",
                       f"{self.keys_before:,}", f"{self.keys_after:,}", share, self.length(self.worst_distance),
                       self.length(self.distance), self.length(self.shell), self.seconds))
        share = 100.0 * self.keys_after / self.keys_before if self.keys_before else 0.0
        proved = [t.bound_deg for t in self.targets if t.proven]
        if proved and len(proved) == len(self.targets):
            between = ", %.4f° at every instant" % max(proved)
        else:
            between = ", between frames not proved within it for %d of them" % (len(self.targets) - len(proved))
        return ("%d target%s, rotation keys %s → %s (%.1f %%), max error %.4f° (bound %g°)%s, %.2f s"
                % (len(self.targets), "" if len(self.targets) == 1 else "s", f"{self.keys_before:,}",
                   f"{self.keys_after:,}", share, self.max_error_deg, self.tolerance, between, self.seconds))

    def length(self, value):
        return length_text(value, *(self.units or ("METRIC", 1.0)))

    def lines(self):
        if self.error == "DISTANCE":
            return ["%s: %d bone%s, %d → %d rotation keys, worst %s at %s, frame %s (%s) in '%s'%s"
                    % (t.name, t.bones, "" if t.bones == 1 else "s", t.keys_before, t.keys_after,
                       self.length(t.worst), t.bone, num(t.frame), t.vertex, t.action,
                       "; %d kept their keys (a reduction needed more): %s" % (
                           len(t.kept), ", ".join(t.kept)) if t.kept else "") for t in self.targets]
        return ["%s (%s): %d → %d keys, %s in '%s'"
                % (t.name, t.mode, t.keys_before, t.keys_after, t.error_text, t.action)
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
    try:
        loop = cycles.loop_of_keys(target, source)
    except TargetError as error:
        raise ReduceError(str(error)) from error
    for index, modifiers in enumerate(source.modifiers):
        if modifiers and loop is None:
            raise ReduceError("%s: %s[%d] has F-curve modifiers; the bound holds for keys alone "
                              "(apply or remove the modifiers first)" % (target.name, source.prop, index))
    frames = native.require().whole_frame_samples(source.frames)  # every whole frame and key
    playback = targets.playback(target)
    values = playback.evaluate(frames)
    if not np.isfinite(values).all():
        raise ReduceError("%s: %s evaluates to non-finite values" % (target.name, source.prop))
    original, between = read_original(playback, frames)
    return TargetReduce(target, source.mode, source.prop, frames, values, source.key_count, original, between,
                        loop=loop, cycles=None if loop is None else cycles.channel_modes(target))


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
    if settings.error == "DISTANCE":
        return reduce_distance(found, settings, begin)
    tol = math.radians(settings.tolerance)

    def read_all():
        with fcurves.read_cache():  # closed once the last target is read, before any write
            for target in found:
                item = read_target(target)
                if not item.keys_before:  # no action keys: the rotation plays from NLA strips alone
                    raise ReduceError("%s: no rotation keys of its own: its rotation plays from NLA strips, and "
                                      "reduction thins an action's keys (bake it first, or clean it, which reads "
                                      "what Blender plays)" % target.name)
                yield item

    def reduce_item(item):
        try:
            # A loop keeps each channel's first and last key: its Cycles modifiers repeat that range.
            item.reduced = reduce_values(item.frames, item.values, item.mode, tol, settings.interpolation,
                                         settings.synchronized, original=item.original, one_key=item.loop is None)
            if item.original is None:
                item.reduced.between = item.between
        except ReduceError as error:
            raise ReduceError("%s: %s" % (item.target.name, error)) from error
        return item

    # Blender is read on this thread, target after target, while worker threads reduce the targets
    # already read (the native reducer runs without the GIL). Into new actions the writing starts as
    # soon as everything is read — copying the action and writing the first targets while the workers
    # reduce the rest — and a failure on the way removes the new actions again; in place, everything
    # is computed before the first key is replaced.
    items, written = [], []

    def writes():
        for item in parallel_imap(reduce_item, read_all()):
            items.append(item)
            if item.untouched:
                continue
            written.append(item)
            yield write.RotationWrite(item.target, item.mode, item.reduced.keys, item.reduced.interpolation,
                                      replace=(item.prop,), cycles=item.cycles,
                                      key_interpolations=item.reduced.key_interpolations)

    actions = write.write_rotations(writes() if settings.new_action else list(writes()),
                                    settings.new_action, "reduced")
    action_of = {id(item): action.name for item, action in zip(written, actions)}
    result = ReduceResult(settings.tolerance, settings.interpolation)
    for item in items:
        if item.untouched:  # its keys as they were: Blender plays them as before
            action = fcurves.active_action(item.target.id_data)
            result.targets.append(TargetResult(
                item.target.name, item.mode, item.keys_before, item.keys_before, 0.0,
                action.name if action is not None else "",
                "max error 0.0000° at every instant — its keys kept as they are: a reduction needs more (%d "
                "keys; %s)" % (item.reduced.key_count, item.between), 0.0, True))
            result.keys_before += item.keys_before
            result.keys_after += item.keys_before
            continue
        action = action_of[id(item)]
        after = item.reduced.key_count
        error_deg = math.degrees(item.reduced.max_error)
        bound = item.reduced.bound
        text = item.reduced.error_text(settings.tolerance)
        if item.reduced.kept_original(item.frames):
            text += (" — the original's keys kept as they are: no reduction within the tolerance was proved "
                     "with fewer keys")
        elif item.reduced.copied is not None and len(item.reduced.copied):
            text += " — the original's keys kept over frames %s (%s)" % (
                ", ".join("%s–%s" % (num(a), num(b)) for a, b in item.reduced.copied),
                "its sign flips, or where no reduction was proved" if item.mode == "QUATERNION"
                else "where no reduction was proved")
        if item.loop is not None:
            text += (" over the loop's period (frames %s–%s, Cycles modifier kept: Blender repeats the reduced "
                     "keys as the original, so in every period)" % (num(item.loop.start), num(item.loop.end)))
        result.targets.append(TargetResult(item.target.name, item.mode, item.keys_before, after,
                                           error_deg, action, text,
                                           None if bound is None else math.degrees(bound),
                                           item.reduced.proof is not None and item.reduced.proof.proven,
                                           [] if item.reduced.copied is None else
                                           [tuple(map(float, e)) for e in item.reduced.copied]))
        result.keys_before += item.keys_before
        result.keys_after += after
        result.max_error_deg = max(result.max_error_deg, error_deg)
    result.seconds = time.perf_counter() - begin
    return result


# ---- the distance bound (error='DISTANCE') ------------------------------------------------------------

VERTEX_NAMES = ("tail", "shell X", "shell Y", "shell Z")
FLOAT32_EPS = 2.0 ** -24


def length_text(value, system="METRIC", scale_length=1.0):
    """A length in scene units as Blender's unit display shows it ('1 mm', '0.98 mm'). Where that
    display loses the value (below 1 µm it reads '0 m'; a few µm in feet keep one digit) it is
    written in µm or thou (without units: the number), so a printed bound reads what it is."""
    import bpy
    meters = value * scale_length
    try:
        text = bpy.utils.units.to_string(system, "LENGTH", meters, precision=4)
        shown = bpy.utils.units.to_value(system, "LENGTH", text)
    except (ValueError, TypeError):
        return "%g" % value
    if abs(shown - meters) <= 1e-3 * abs(meters):
        return text.strip()
    if system == "IMPERIAL":
        return "%.4g thou" % (meters / 2.54e-5)
    if system == "METRIC":
        return "%.4g µm" % (meters * 1e6)
    return "%.4g" % meters


def scene_lengths(settings, scene):
    """(distance, shell) in scene units: the settings', 0 taking 1 mm / 10 cm in real size."""
    scale = scene.unit_settings.scale_length or 1.0
    return (settings.distance or DEFAULT_DISTANCE / scale, settings.shell or DEFAULT_SHELL / scale)


@dataclass(eq=False)
class SkeletonReduce:
    read: object                # skeleton.ReadSkeleton
    distance: float             # the native target: the bound less Blender's float32 posing slack
    shell: float
    result: object = None       # quatcurve.SkeletonReduction (None: every bone asked for kept its keys)
    kept: list = field(default_factory=list)  # bone indices kept with their own keys (reduce_item)


def float32_slack(read, shell):
    """What Blender's float32 posing of both motions may add to a distance: a few float32 steps of
    the farthest virtual vertex per level of the deepest chain."""
    qc = native.require()
    quats = np.array([qc.channels_to_quats(v, mode) for mode, v in read.rotations])
    sk = read.skeleton()
    verts = sk.virtual_vertices(sk.pose(read.locations, quats, read.scales), shell)
    extent = float(np.abs(verts).max()) if verts.size else 0.0
    depth = np.zeros(len(read.parents), dtype=int)
    for b, p in enumerate(read.parents):
        depth[b] = 0 if p < 0 else depth[p] + 1
    return 16.0 * (int(depth.max()) + 1) * FLOAT32_EPS * extent


def reduce_distance(found, settings, begin):
    """The reduction under the distance bound: per armature, the selected bones' rotation keys
    reduced by quatcurve.Skeleton.reduce with every bone posed (unselected bones as they are); per
    object, its own three shell points. Returns a ReduceResult with one SkeletonResult per armature
    or object. Raises ReduceError (nothing written) as skeleton.py refuses."""
    import bpy
    from . import skeleton
    scene = bpy.context.scene
    distance, shell = scene_lengths(settings, scene)
    groups = {}
    for target in found:
        groups.setdefault(target.object.name_full, (target.object, []))[1].append(target)
    items = []
    try:
        for obj, group in groups.values():
            bones = [t.bone for t in group if t.bone is not None]
            if bones:
                read = skeleton.read_armature(obj, bones)
                items.append(SkeletonReduce(read, 0.0, shell))
            if any(t.bone is None for t in group):
                items.append(SkeletonReduce(skeleton.read_object(obj), 0.0, shell))
        for item in items:
            slack = float32_slack(item.read, shell)
            if slack >= 0.5 * distance:
                raise ReduceError("%s: a distance of %s is below what Blender's float32 posing keeps at this size "
                                  "(%s)" % (item.read.object.name, length_text(distance), length_text(2 * slack)))
            item.distance = distance - slack
    except TargetError as error:
        raise ReduceError(str(error)) from error

    def reduce_item(item):
        # A bone whose reduction keeps more keys than it has (sparse keys to LINEAR output)
        # keeps its own keys instead, and the others are reduced again around it, posed as it plays:
        # the distance the result reports is the written keys' (each round keeps at least one more).
        read = item.read
        while np.any(read.reduced):
            try:
                item.result = read.skeleton().reduce(read.frames, read.rotations, read.locations, read.scales,
                                                     item.distance, item.shell, settings.interpolation,
                                                     settings.synchronized, reduced=read.reduced)
            except ValueError as error:
                raise ReduceError("%s: %s" % (read.object.name, error)) from error
            if item.result.error.distance > item.distance:
                raise ReduceError("%s: no reduction keeps every virtual vertex within %s (the float32 floor of the "
                                  "keys reaches %s)" % (read.object.name, length_text(distance),
                                                        length_text(item.result.error.distance)))
            grown = [b for b in np.flatnonzero(read.reduced) if item.result.keys[b].key_count > read.keys_before[b]]
            if not grown:
                break
            read.reduced = read.reduced.copy()
            read.reduced[grown] = False
            item.kept.extend(int(b) for b in grown)
            item.result = None
        return item

    done = list(parallel_imap(reduce_item, iter(items)))  # everything computed before the first write
    writes, owners = [], []
    for item in done:
        bezier = settings.interpolation == "BEZIER"
        for b in np.flatnonzero(item.read.reduced):
            keys = [(ch.frames, ch.values, ch.handle_left if bezier else None, ch.handle_right if bezier else None)
                    for ch in item.result.keys[b].channels]
            writes.append(write.RotationWrite(item.read.targets[b], item.read.rotations[b][0], keys,
                                              settings.interpolation, replace=(item.read.props[b],)))
            owners.append(item)
    actions = write.write_rotations(writes, settings.new_action, "reduced")
    units = scene.unit_settings
    result = ReduceResult(settings.tolerance, settings.interpolation, error="DISTANCE", distance=distance,
                          shell=shell, units=(units.system, units.scale_length or 1.0))
    action_of = {id(item): action.name for item, action in zip(owners, actions)}
    for item in done:
        read = item.read
        chosen = np.flatnonzero(read.reduced)
        kept = int(read.keys_before[item.kept].sum())
        before = int(read.keys_before[chosen].sum()) + kept
        after = int(sum(item.result.keys[b].key_count for b in chosen)) + kept
        if item.result is not None and item.result.error.bone >= 0:
            error = item.result.error
            worst, bone, frame = error.distance, read.names[error.bone], float(read.frames[error.sample])
            vertex = VERTEX_NAMES[error.vertex]
        else:  # nothing reduced, or nowhere off: the keys play as they did
            worst, bone, frame, vertex = 0.0 if item.result is None else item.result.error.distance, "-", \
                float(read.frames[0]), "-"
        result.targets.append(SkeletonResult(read.object.name, len(chosen) + len(item.kept), before, after, worst, bone,
                                             frame, vertex, action_of.get(id(item), ""), result.length(worst),
                                             tuple(read.names[b] for b in item.kept)))
        result.keys_before += before
        result.keys_after += after
        result.worst_distance = max(result.worst_distance, worst)
    result.seconds = time.perf_counter() - begin
    return result
