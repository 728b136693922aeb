"""Convert: change the rotation mode of objects and pose bones, keeping the motion Blender plays.

    found = targets.gather_targets(bpy.context, verb="convert")
    result = convert.convert(found, convert.ConvertSettings(rotation_mode="QUATERNION", tolerance=0.05))
    print(result.summary())

For each target (in its active action, or with actions='ALL' in every action that animates its
rotation) the rotation Blender plays now is read as Blender plays it: each channel of the current
mode is evaluated by Blender (fcurves.evaluate: any interpolation, handles, easing) at every
1/subframes frame over the keyed range and at every key, and the channels are turned into the
rotation as Blender builds it (native channels_to_quats). Those dense rotations become channel values
of the new mode, continuous along the samples (native quats_to_channels: quaternion signs in one
hemisphere from sample to sample, Euler angles without flips or 360° jumps, so spins survive;
starting from the source's own values when source and target are both Euler, both quaternion or both
axis-angle). The native fitter then writes BEZIER keys in the new mode: a key on every frame that had
an animator key on any rotation channel (its key type and selection carried over) and as few
generated keys (GENERATED, JITTER on Blender 3.4) as the tolerance needs, so that Blender's evaluation
of the new channels stays within `tolerance` degrees of the rotation played before: at every instant
of the keyed range where Blender's playback of the old keys is emulated bit for bit (every segment
Bezier, or every one linear: reduce.read_original), proved against it (quatcurve.convert_keys_proved);
otherwise at every sample (quatcurve.fit_keys, verified by emulating Blender's F-curve evaluation),
and the result line says why it is not proved between them. Blocking keys (every key CONSTANT) become
CONSTANT keys of the new mode at every key frame (stepped_plan): the same steps at the same frames.

Keys typed GENERATED in the source are a fit's or an earlier conversion's: they are resampled, not
kept. The old rotation channels are removed, the new ones made in the same group, and the rotation
mode set. Everything is read and planned first; an error (drivers, library or override data, F-curve
modifiers, muted channels, NaN keys, zero quaternions) names the target, the action and the channel,
and nothing is changed. A fitted target keeps its fit record (rewritten for the new property and the
converted keys, so live refit sees no change until the animator edits a key, and then refits the
method in the new mode); its per-key ease records are by frame and stay as they are.
"""

import math
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import cycles, fcurves, fit, methods, native, reduce, targets
from .workers import parallel_imap
from .targets import TargetError

MODES = ("QUATERNION",) + fcurves.EULER_ORDERS + ("AXIS_ANGLE",)
ACTIONS = ("ACTIVE", "ALL")


class ConvertError(TargetError):
    """A conversion that cannot be done; the message names the target, action and channel. Raised
    before anything is written."""


@dataclass
class ConvertSettings:
    """rotation_mode: the new mode (MODES); tolerance: degrees, the largest angle between Blender's
    playback after and before the conversion (at every instant where proved, else at every sample);
    subframes: samples per frame;
    actions: 'ACTIVE' (the action each target plays) or 'ALL' (every action animating its rotation)."""
    rotation_mode: str = "QUATERNION"
    tolerance: float = 0.05
    subframes: int = 4
    actions: str = "ACTIVE"


def check_settings(settings):
    if settings.rotation_mode not in MODES:
        raise ConvertError("rotation mode %r: not one of %s" % (settings.rotation_mode, ", ".join(MODES)))
    if not (settings.tolerance > 0) or not math.isfinite(settings.tolerance):
        raise ConvertError("tolerance %r°: must be a finite angle above 0" % (settings.tolerance,))
    if not (1 <= int(settings.subframes) <= 64) or int(settings.subframes) != settings.subframes:
        raise ConvertError("subframes %r: must be a whole number from 1 to 64" % (settings.subframes,))
    if settings.actions not in ACTIONS:
        raise ConvertError("actions %r: must be ACTIVE or ALL" % (settings.actions,))


def family(mode):
    return "EULER" if mode in fcurves.EULER_ORDERS else mode


# ---- reading ------------------------------------------------------------------------------------------

@dataclass(eq=False)
class Source:
    """One target's rotation in one action, read. Planning uses only the plain arrays and strings (it
    runs on worker threads); target, action and channels (the Channels holding the keys) are for the
    writing, on the main thread.

    where: 'target (action …)' for messages; times (N,): the samples (every 1/subframes frame over the keyed range, and every key); quats (N, 4):
    the rotation Blender plays there; first (C,): the source channels' values at times[0]; forced
    (F,): indices in times of the frames that get a key in the new mode (every animator key frame
    and both ends of the range); types (F,) and selected (F,): their key types and selection;
    source_keys: how many keys the old channels held; loop: the cycles.Loop its Cycles modifiers make
    (one period is sampled: Blender repeats it), None when open."""
    target: object
    name: str
    where: str
    action: object
    channels: object
    slot: str
    mode: str
    prop: str
    path: str
    group: object
    times: np.ndarray
    quats: np.ndarray
    first: np.ndarray
    forced: np.ndarray
    types: np.ndarray
    selected: np.ndarray
    source_keys: int
    loop: cycles.Loop = None
    original: tuple = None  # reduce.read_original's (channels, interpolation): the playback the proof emulates
    between: str = ""       # why the conversion is not proved between samples (original is None)
    stepped: bool = False   # every key CONSTANT (blocking): forced holds every key frame, and each one's
                            # rotation becomes a CONSTANT key of the new mode (plan)


def _where(target, action):
    return "%s (action '%s')" % (target.name, action.name)


def read_source(target, action, channels, slot, mode, subframes):
    """The Source of `target` in `action` (its `channels`), read in rotation mode `mode`; None when the
    mode's channels have no keys there. Raises ConvertError for protected actions, F-curve modifiers,
    muted channels, non-finite keys or handles, and zero rotations."""
    qc = native.require()
    prop, count = fcurves.rotation_property(mode)
    path = target.data_path(prop)
    curves = [c if c is not None and fcurves.key_count(c) else None for c in channels.find_all(path, count)]
    if not any(c is not None for c in curves):
        return None
    where = _where(target, action)
    why = fcurves.is_protected(action)
    if why:
        raise ConvertError("%s: the action is %s and cannot be changed" % (where, why))
    try:
        loop = cycles.target_loop(where, prop, curves, mode, action)
    except TargetError as error:
        raise ConvertError(str(error)) from None
    frames_all, animator, per_channel, source_keys = [], [], [], 0
    for c, curve in enumerate(curves):
        if curve is None:
            per_channel.append(None)
            continue
        if curve.mute:
            raise ConvertError("%s: %s[%d] is muted (Blender does not play it): unmute or delete it first"
                               % (where, prop, c))
        frames, values = fcurves.read_keys(curve)
        left, right = fcurves.read_handles(curve)
        for what, array in (("frame", frames), ("value", values), ("handle", left), ("handle", right)):
            bad = ~np.isfinite(array.reshape(len(frames), -1)).all(axis=1)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise ConvertError("%s: %s[%d] key %d has a non-finite %s (%s)"
                                   % (where, prop, c, k, what, array.reshape(len(frames), -1)[k].tolist()))
        types = fcurves.read_key_types(curve)
        selected = fcurves.read_key_selection(curve)
        per_channel.append((frames, types, selected))
        frames_all.append(frames)
        animator.append(frames[types != fit.KEY_TYPE_GENERATED])
        source_keys += len(frames)
    keyed = np.unique(np.concatenate(frames_all))
    animator = np.unique(np.concatenate(animator))
    forced_frames = np.union1d(animator, keyed[[0, -1]])
    # Blocking keys: every segment of every channel CONSTANT, constant extrapolation, no loop. The
    # rotation then changes only at key frames (of any channel): keyed in the new mode at all of them,
    # CONSTANT, it plays the same steps at the same frames.
    present = [c for c in curves if c is not None]
    kinds = [fcurves.segment_interpolations(c) for c in present]
    stepped = (loop is None and any(kinds) and all(k <= {"CONSTANT"} for k in kinds)
               and all(c.extrapolation == "CONSTANT" for c in present))
    if stepped:
        forced_frames = keyed
    times = qc.sample_frames(keyed, int(subframes))
    values = targets.evaluate_channels(target, prop, curves, times)
    bad = ~np.isfinite(values)
    if bad.any():
        k, c = np.argwhere(bad)[0]
        raise ConvertError("%s: %s[%d] plays %s at frame %s" % (where, prop, c, values[k, c], targets.num(times[k])))
    try:
        quats = targets.channels_to_quats(mode, values, where, times)
    except TargetError as error:
        raise ConvertError(str(error)) from None
    forced = np.searchsorted(times, forced_frames)
    types = np.full(len(forced_frames), fit.KEY_TYPE_GENERATED, dtype=np.int64)
    selected = np.zeros(len(forced_frames), dtype=bool)
    for frames, key_types, key_selected in reversed([p for p in per_channel if p is not None]):
        at = np.searchsorted(forced_frames, frames)
        on = (at < len(forced_frames)) & (forced_frames[np.minimum(at, len(forced_frames) - 1)] == frames)
        mine = on & (key_types != fit.KEY_TYPE_GENERATED)
        types[at[mine]] = key_types[mine]  # the first channel keyed there wins (read last)
        selected[at[on]] |= key_selected[on]
    original, between = reduce.read_original(targets.Playback(target, mode, prop, curves, False), times)
    if original is not None and loop is not None and any(
            p is not None and (p[0][0] != keyed[0] or p[0][-1] != keyed[-1]) for p in per_channel):
        original, between = None, "its loop's channels have different keyed ranges"
    # F-curves without a group go into the one Blender's keying would make (the bone's name, or
    # "Object Transforms"), where tools that look channels up by group (Rigify's) find them.
    group = channels.group_of(path, count) or (target.bone if target.bone is not None else "Object Transforms")
    return Source(target, target.name, where, action, channels, slot, mode, prop, path, group,
                  times, quats, values[0].copy(), forced.astype(np.int64), types, selected, source_keys, loop,
                  original, between, stepped)


def refuse_drivers(target, modes):
    """A driver on a rotation channel of the old or the new mode plays instead of any keys: refused."""
    anim = target.id_data.animation_data
    if anim is None:
        return
    for mode in modes:
        prop, count = fcurves.rotation_property(mode)
        path = target.data_path(prop)
        for i in range(count):
            if anim.drivers.find(path, index=i) is not None:
                raise ConvertError("%s: %s[%d] is driven by a driver, which Blender plays instead of keys: "
                                   "remove the driver first" % (target.name, prop, i))


def refuse_shared(work, played_by):
    """An action's channels played by another object (the same action and slot) change for it too: that
    object must be converted with the target (the same bone of it, for a pose bone), else refused."""
    converting = {(target.id_data.name, target.bone) for target, _, sources in work if sources}
    for target, _, sources in work:
        for source in sources:
            for other in sorted(played_by.get((source.action.as_pointer(), source.slot), ())):
                if other == target.id_data.name or (other, target.bone) in converting:
                    continue
                obj = bpy.data.objects.get(other)
                if target.bone is not None and (obj is None or obj.pose is None or target.bone not in obj.pose.bones):
                    continue
                raise ConvertError("%s: %s is also played by '%s'%s, which is not being converted: select it too, "
                                   "or give it an action of its own" % (
                                       _where(target, source.action), source.prop, other,
                                       " (bone '%s')" % target.bone if target.bone is not None else ""))


def _has_keys(channels, path, count):
    return channels is not None and any(
        c is not None and fcurves.key_count(c) for c in channels.find_all(path, count))


def players():
    """{(action pointer, slot identifier or ''): {object names}}: who plays which action (as its active
    action or in an NLA strip), through which slot (≥ 4.4; '' before)."""
    found = {}
    for obj in bpy.data.objects:
        anim = obj.animation_data
        if anim is None:
            continue
        uses = [(anim.action, getattr(anim, "action_slot", None))] if anim.action is not None else []
        uses += [(strip.action, getattr(strip, "action_slot", None)) for track in anim.nla_tracks
                 for strip in track.strips if strip.action is not None]
        for action, slot in uses:
            key = (action.as_pointer(), slot.identifier if fcurves.SLOTTED and slot is not None else "")
            found.setdefault(key, set()).add(obj.name)
    return found


def _action_slot(target, action, path, count, played_by):
    """(Channels, slot identifier, note) of `target` in `action` for `path`, or (None, '', note):
    - the slot the target plays the action through (active or NLA), if it animates `path`;
    - else a slot no other object plays: the one named like the target's slot, or — for a pose bone,
      whose path names the bone — the only such slot animating `path` (an action of a motion library
      made for another copy of the rig). An object's path ('rotation_euler') names no object, so an
      unplayed action is taken for an object only through a slot named like its own.
    `played_by`: players()."""
    id_data = target.id_data
    mine = id_data.name
    if not fcurves.SLOTTED:
        users = played_by.get((action.as_pointer(), ""), set())
        if getattr(action, "id_root", "OBJECT") not in ("OBJECT", "") or (users and mine not in users):
            return None, "", ""
        if not users and target.bone is None:
            return None, "", ""
        channels = fcurves.Channels.of_slot(action)
        return (channels, "", "") if _has_keys(channels, path, count) else (None, "", "")
    played = fcurves.played_slot(id_data, action)
    if played is not None:
        channels = fcurves.Channels.of_slot(action, played)
        return (channels, played.identifier, "") if _has_keys(channels, path, count) else (None, "", "")
    identifier = fcurves.slot_identifier(id_data) or "OB" + id_data.name
    found = []
    for slot in fcurves.action_slots(action):
        if getattr(slot, "target_id_type", "OBJECT") not in ("OBJECT", "UNSPECIFIED"):
            continue
        if played_by.get((action.as_pointer(), slot.identifier)):
            continue  # another object's animation
        channels = fcurves.Channels.of_slot(action, slot)
        if _has_keys(channels, path, count):
            found.append((slot, channels))
    exact = [f for f in found if f[0].identifier == identifier]
    if exact:
        return exact[0][1], exact[0][0].identifier, ""
    if target.bone is None:
        return None, "", ""
    if len(found) == 1:
        return found[0][1], found[0][0].identifier, ""
    if found:
        return None, "", ("%s: action '%s' animates %s in %d slots (%s), none of them %s: left as it is"
                          % (target.name, action.name, path, len(found), ", ".join(f[0].identifier for f in found),
                             identifier))
    return None, "", ""


def target_actions(target, which, mode, played_by):
    """[(action, Channels, slot identifier)] to convert for `target` (rotation mode `mode`), and notes.
    ACTIVE: its active action (no active action but NLA strips: ConvertError). ALL: every action in the
    file animating the mode's rotation channels of the target (see _action_slot). played_by: players()."""
    prop, count = fcurves.rotation_property(mode)
    path = target.data_path(prop)
    notes = []
    if which == "ACTIVE":
        action = fcurves.active_action(target.id_data)
        if action is None and fcurves.nla_strips(target.id_data):
            raise ConvertError("%s: no active action, only NLA strips: convert the strips' actions with "
                               "actions='ALL', or enter tweak mode on the strip" % target.name)
        channels = fcurves.Channels.of(target.id_data, action) if action is not None else None
        others = 0
        for other in bpy.data.actions:
            if other != action and _action_slot(target, other, path, count, played_by)[0] is not None:
                others += 1
        if others:
            notes.append("%s: %d other action%s animate%s its %s: %s no longer play%s as before in the new mode "
                         "(convert with actions='ALL')" % (target.name, others, "" if others == 1 else "s",
                                                           "s" if others == 1 else "", prop,
                                                           "it" if others == 1 else "they",
                                                           "s" if others == 1 else ""))
        if not _has_keys(channels, path, count):
            return [], notes
        return [(action, channels, fcurves.slot_identifier(target.id_data) or "")], notes
    found = []
    for action in sorted(bpy.data.actions, key=lambda a: a.name):
        channels, slot, note = _action_slot(target, action, path, count, played_by)
        if note:
            notes.append(note)
        if channels is not None:
            found.append((action, channels, slot))
    return found, notes


def _find_record(action, slot, owner_path):
    for record in getattr(action, "quatcurve_fits", ()):
        if record.slot == slot and record.owner_path == owner_path:
            return record
    return None


# ---- planning (plain arrays, native) -----------------------------------------------------------------

@dataclass(eq=False)
class Plan:
    """What convert writes for one Source: per channel of the new mode (frames, values, handle_left,
    handle_right, types, selected), the fit's error at the samples (radians, Blender's evaluation
    emulated) and the proof's bound at every instant from the first sample to the last (radians; None
    when not proved: Source.between says why), with the frame where the bound is reached."""
    source: Source
    mode: str
    prop: str
    channels: list
    max_error: float
    keys: int
    generated: int
    bound: float = None
    worst_frame: float = None
    interpolation: str = "BEZIER"  # of every key written (CONSTANT: blocking keys, stepped_plan)


def stepped_plan(source, mode, prop, reference):
    """Blocking keys (Source.stepped) in the new mode: at every key frame, the rotation Blender plays
    there as CONSTANT keys (channel values continuous from key to key). Both play a constant rotation
    from one key frame to the next and change at the same frames, so the angle between them at every
    instant is the angle at the keys, between the old rotation and the one Blender builds from the new
    keys as stored (float32): that is the bound, proved, with no key generated."""
    qc = native.require()
    at_keys = source.quats[source.forced]
    values = qc.quats_to_channels(at_keys, mode, reference).astype(np.float32).astype(np.float64)
    angles = qc.angle_between(qc.channels_to_quats(values, mode), at_keys)
    frames = source.times[source.forced]
    worst = int(np.argmax(angles))
    channels = [(frames.copy(), values[:, c].copy(), np.column_stack([frames, values[:, c]]),
                 np.column_stack([frames, values[:, c]]), source.types.copy(), source.selected.copy())
                for c in range(values.shape[1])]
    generated = int((source.types == fit.KEY_TYPE_GENERATED).sum()) * values.shape[1]
    bound = float(angles[worst])
    return Plan(source, mode, prop, channels, bound, len(frames) * values.shape[1], generated, bound,
                float(frames[worst]), "CONSTANT")


def plan(source, settings):
    """The new mode's keys for one Source (nothing written; no Blender data read: may run on a worker)."""
    qc = native.require()
    mode = settings.rotation_mode
    prop, _ = fcurves.rotation_property(mode)
    reference = source.first if family(mode) == family(source.mode) else None
    bound = worst = None
    if source.stepped:
        try:
            return stepped_plan(source, mode, prop, reference)
        except ValueError as error:
            raise ConvertError("%s: %s" % (source.where, error)) from None
    try:
        values = qc.quats_to_channels(source.quats, mode, reference)
        if source.original is not None:
            channels_in, interpolation = source.original
            proved = qc.convert_keys_proved(channels_in, interpolation, source.mode, mode, source.times, values,
                                            source.forced, math.radians(settings.tolerance), fit.MIN_KEY_GAP)
            fitted, bound, worst = proved.keys, proved.proof.bound, proved.proof.worst_time
        else:
            fitted = qc.fit_keys(source.times, values, source.forced, math.radians(settings.tolerance), mode=mode,
                                 interpolation="BEZIER", synchronized=False, min_gap=fit.MIN_KEY_GAP)
    except ValueError as error:
        raise ConvertError("%s: %s" % (source.where, error)) from None
    channels, keys, generated = [], 0, 0
    forced_frames = source.times[source.forced]
    F = len(forced_frames)
    for ch in fitted.channels:
        # By frame: the proof's added samples shift the fit's indices past source.times.
        at = np.searchsorted(forced_frames, ch.frames)
        on = (at < F) & (forced_frames[np.minimum(at, F - 1)] == ch.frames)
        types = np.full(len(ch.frames), fit.KEY_TYPE_GENERATED, dtype=np.int64)
        types[on] = source.types[at[on]]
        selected = np.zeros(len(ch.frames), dtype=bool)
        selected[on] = source.selected[at[on]]
        keys += len(ch.frames)
        generated += int((types == fit.KEY_TYPE_GENERATED).sum())
        channels.append((ch.frames.copy(), ch.values.copy(), ch.handle_left.copy(), ch.handle_right.copy(),
                         types, selected))
    return Plan(source, mode, prop, channels, fitted.max_error, keys, generated, bound, worst)


# ---- writing ------------------------------------------------------------------------------------------

def write_plan(plan):
    """Replaces the source's rotation channels in its action by the plan's (same group; any keys the new
    property had there, which did not play, are replaced too) and rewrites a fit record."""
    source = plan.source
    new_path = source.target.data_path(plan.prop)
    source.channels.remove(sorted({source.path, new_path}), count=4)
    modes = loop_modes(plan)
    for c, (frames, values, left, right, types, selected) in enumerate(plan.channels):
        curve = source.channels.new_fcurve(new_path, c, group=source.group)
        if modes is not None:
            cycle = curve.modifiers.new("CYCLES")
            cycle.mode_before = cycle.mode_after = modes[c]
        fcurves.write_keys(curve, frames, values, interpolation=plan.interpolation, handle_left=left,
                           handle_right=right)
        fcurves.write_key_types(curve, types)
        fcurves.write_key_selection(curve, selected)
    record = _find_record(source.action, source.slot, _owner_path(source.target))
    if record is not None:
        record.prop = plan.prop
        record.signature = _signature(plan, new_path)
        # The new playback is within the conversion's bound of the old, which was within the fit's of
        # the method: the sum bounds it (the angle between rotations is a metric).
        known = record.bound >= 0.0 and plan.bound is not None
        record.bound = record.bound + plan.bound if known else -1.0


def loop_modes(plan):
    """Per new channel, the Cycles mode that keeps a loop (None when the source is open). One period
    was converted, and Blender repeats it: Repeat where the period ends on the values it starts from,
    Repeat with Offset on an Euler or axis-angle channel that ends whole turns from where it started
    (a wheel keeps turning in its channels). A quaternion channel always repeats: a wheel's period
    ends on the first rotation's negative, the same rotation, and the next period turns the same."""
    if plan.source.loop is None:
        return None
    modes = []
    for c, (frames, values, _, _, _, _) in enumerate(plan.channels):
        step = float(values[-1] - values[0])
        angle = plan.mode in fcurves.EULER_ORDERS or (plan.mode == "AXIS_ANGLE" and c == 0)
        offset = angle and abs(step) > 1e-4 and abs(step - 2 * math.pi * round(step / (2 * math.pi))) <= 1e-4
        modes.append("REPEAT_OFFSET" if offset else "REPEAT")
    return modes


def _owner_path(target):
    return target.owner.path_from_id() if target.bone is not None else ""


def _signature(plan, path):
    """The fit record signature of the written keys: what fit.read_animator_keys will read back (the
    animator keys of every channel, as float32), so live mode sees the converted keys as fitted."""
    frames = values = types = None
    columns = []
    for ch_frames, ch_values, _, _, ch_types, _ in plan.channels:
        mine = ch_types != fit.KEY_TYPE_GENERATED
        if frames is None:
            frames = ch_frames[mine].astype(np.float32).astype(np.float64)
            types = ch_types[mine].astype(np.int64)
        columns.append(ch_values[mine].astype(np.float32).astype(np.float64))
    values = np.stack(columns, axis=1)
    modes = loop_modes(plan)
    loop = None if modes is None else cycles.Loop(float(frames[0]), float(frames[-1]), "REPEAT_OFFSET" in modes)
    keys = fit.AnimatorKeys(plan.source.name, plan.mode, plan.prop, path, frames, values, types,
                            np.zeros((len(columns), len(frames)), dtype=bool), loop)
    return keys.signature()


# ---- the task -------------------------------------------------------------------------------------------

@dataclass
class TargetResult:
    name: str
    from_mode: str
    to_mode: str
    # (action name, keys before, keys after, generated, max error ° at the samples, bound ° at every
    # instant or None, the frame of the bound, why not proved)
    actions: list = field(default_factory=list)
    skipped: str = ""
    notes: list = field(default_factory=list)

    def line(self, tolerance):
        if self.skipped:
            return "%s: %s" % (self.name, self.skipped)
        if not self.actions:
            return "%s: %s → %s, no rotation keys (the pose is kept)" % (self.name, self.from_mode, self.to_mode)
        parts = []
        for action, before, after, generated, error, bound, worst, between in self.actions:
            if bound is None:
                over = "" if error <= tolerance else " ABOVE the tolerance: keys too close to insert between"
                how = "max error %.4f° at every checked point%s (not proved between them: %s)" % (error, over, between)
            else:
                over = ("" if bound <= tolerance else " ABOVE the tolerance near frame %s: 8 fits with the proof's "
                        "failing times added as samples did not bring the keys within it there" % targets.num(worst))
                how = "within %.4f° at every instant%s (max error %.4f° at the samples)" % (bound, over, error)
            parts.append("'%s' %d → %d keys (%d generated), %s" % (action, before, after, generated, how))
        return "%s: %s → %s: %s" % (self.name, self.from_mode, self.to_mode, "; ".join(parts))


@dataclass
class ConvertResult:
    settings: ConvertSettings
    targets: list = field(default_factory=list)
    seconds: float = 0.0

    @property
    def converted(self):
        return [t for t in self.targets if not t.skipped]

    def summary(self):
        done = self.converted
        rows = [a for t in done for a in t.actions]
        bounds = [a[5] for a in rows if a[5] is not None]
        within = sum(b <= self.settings.tolerance for b in bounds)
        above = len(bounds) - within
        return ("Converted %d target%s to %s (%d action%s, %d → %d keys, %d generated, max error %.4f° at the "
                "samples; %d of %d proved within the tolerance at every instant%s) in %.2f s"
                % (len(done), "" if len(done) == 1 else "s", self.settings.rotation_mode, len({a[0] for a in rows}),
                   "" if len({a[0] for a in rows}) == 1 else "s", sum(a[1] for a in rows), sum(a[2] for a in rows),
                   sum(a[3] for a in rows), max([a[4] for a in rows] or [0.0]), within, len(rows),
                   ", %d ABOVE it (bound %.4f°)" % (above, max(bounds)) if above else "", self.seconds))

    def lines(self):
        return [t.line(self.settings.tolerance) for t in self.targets] + [n for t in self.targets for n in t.notes]


def convert(found, settings):
    """Converts every target (see the module docstring): reads and plans all of them first, then
    writes; an error leaves everything untouched. Targets already in the mode are named and left
    alone. Raises ConvertError."""
    check_settings(settings)
    start = time.perf_counter()
    result = ConvertResult(settings)
    work = []
    played_by = players()
    with fcurves.read_cache():
        # The main thread reads source after source while worker threads plan the ones read already.
        planned = list(parallel_imap(lambda s: plan(s, settings), _read(found, settings, played_by, result, work)))
    refuse_shared(work, played_by)
    plans = iter(planned)
    for target, row, sources in work:
        for source in sources:
            p = next(plans)
            row.actions.append((source.action.name, source.source_keys, p.keys, p.generated,
                                math.degrees(p.max_error), None if p.bound is None else math.degrees(p.bound),
                                p.worst_frame, source.between))
    plans = iter(planned)
    for target, row, sources in work:
        for _ in sources:
            write_plan(next(plans))
        target.owner.rotation_mode = settings.rotation_mode
        target.id_data.update_tag(refresh={"TIME"})
    result.seconds = time.perf_counter() - start
    return result


def _read(found, settings, played_by, result, work):
    """Yields the Source of every target and action to convert (main thread), noting per target in
    `result` and `work` (target, TargetResult, [Source])."""
    mode = settings.rotation_mode
    new_prop, new_count = fcurves.rotation_property(mode)
    for target in found:
        try:
            targets.check_editable(target, new_action=False)
        except TargetError as error:
            raise ConvertError(str(error)) from None
        source_mode = target.owner.rotation_mode
        row = TargetResult(target.name, source_mode, mode)
        result.targets.append(row)
        if source_mode == mode:
            row.skipped = "already %s: left as it is" % mode
            continue
        refuse_drivers(target, (source_mode, mode))
        pairs, row.notes = target_actions(target, settings.actions, source_mode, played_by)
        sources = []
        work.append((target, row, sources))
        for action, channels, slot in pairs:
            source = read_source(target, action, channels, slot, source_mode, settings.subframes)
            if source is None:
                continue
            if new_prop != source.prop and _has_keys(channels, target.data_path(new_prop), new_count):
                row.notes.append("%s: %s had keys that did not play in %s: replaced by the converted ones"
                                 % (_where(target, action), new_prop, source_mode))
            record = _find_record(action, slot, _owner_path(target))
            if record is not None:
                row.notes.append("%s: fitted (%s, %.3g°): the fit record follows to %s; the converted keys play "
                                 "within %.3g° of the fitted playback (fit again for the fit's own tolerance)"
                                 % (_where(target, action), methods.label(record.method), record.tolerance, new_prop,
                                    settings.tolerance))
            sources.append(source)
            yield source
