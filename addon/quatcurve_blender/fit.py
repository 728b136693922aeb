"""Fit: the animator's own sparse rotation keys play a quatcurve method in Blender itself.

    found = targets.gather_targets(bpy.context, verb="fit")
    result = fit.fit(found, fit.FitSettings(method="SQUAD", tolerance=0.05))
    print(result.summary())

Blender's evaluator is not replaced: its own F-curves are shaped so that it plays the method. For
each target the animator's rotation keys stay where they are — same frames, same values (quaternion
signs may be flipped so that neighbours share a hemisphere) — and the native fitter
(`quatcurve.fit_keys`, the reducer with forced keys) sets their Bezier handles (FREE) and inserts as
few keys as the tolerance needs, so that Blender's evaluation, with no add-on loaded, stays within
the tolerance of the method's curve at every instant from the first key to the last — checked at
every frame, `subframes` points per frame and every key, and proved between them from bounds of both
motions' speed and acceleration (`quatcurve.fit_through_keys`, native/include/quatcurve/bound.hpp),
on an emulation of Blender's F-curve evaluation that tests/blender/test_blender_eval.py checks
against Blender. Where the method reaches an Euler key on another branch, the channels change
branch once, beside a key at gimbal lock or nearest the lock (the result says where). Quaternion channels need not stay unit between keys: Blender normalizes when it
builds the rotation, and the fit uses that freedom.

Inserted keys are marked: keyframe type GENERATED (Blender 4.2+) or, on Blender 3.4 which lacks it,
JITTER (the documented stand-in). A refit replaces every marked key and keeps every other one, so an
animator who wants to keep an inserted key changes its type to Keyframe.

Per target the action stores a fit record (`Action.quatcurve_fits`: method, settings, the animator
keys' signature — what live mode compares), per key ease in / ease out (`Action.quatcurve_eases`)
and, for quaternion targets, per key turns (`Action.quatcurve_turns`: extra full turns of the segment
leaving the key, set_turns; axis-angle targets hold theirs in the angle keys), both by frame and carried along when keys move. Rotation modes:
quaternion, the six Euler orders (turns over 180° between Euler keys are kept, as the bake keeps
them) and axis-angle (the angle channel's turns are kept too: 0° → 720° spins twice, as Blender's
own channels do; inserted keys continue the animator's angle and axis side, and the axis length may
drift between keys, as Blender normalizes it). Everything is read and computed before anything is
written, so an error leaves the file untouched; the operator's UNDO flag makes the write one undo
step.
"""

import contextlib
import hashlib
import math
import re
import time
from dataclasses import dataclass, field, replace

import bpy
import numpy as np

from . import cycles, fcurves, methods, native, path_rule, targets
from .workers import thread_count
from .targets import TargetError

METHODS = methods.CURVE_METHODS
# Raw Keyframe.type values (foreach_get/foreach_set): KEYFRAME 0, EXTREME 1, BREAKDOWN 2, JITTER 3,
# MOVING_HOLD 4, GENERATED 5 (4.2+).
KEY_TYPE_KEYFRAME = 0
KEY_TYPE_GENERATED = 5 if bpy.app.version >= (4, 2, 0) else 3
GENERATED_NAME = "GENERATED" if bpy.app.version >= (4, 2, 0) else "JITTER"
# Blender 4.x merges keys closer than this on fcurve.update(): inserted keys keep their distance.
MIN_KEY_GAP = 0.01


class FitError(TargetError):
    """A fit that cannot be done; the message names the target, channel and frame. Raised before
    anything is written."""


@dataclass
class FitSettings:
    """method: the curve Blender should play through the keys; tolerance in degrees (largest rotation
    error of Blender's evaluation against the method at every frame and subframe); tension,
    continuity, bias (TCB); shortest_path (SLERP); clamped (SQUAD, TCB, CATMULL_ROM: overshoot-free
    tangents); subframes: checked points per frame (4: every quarter frame)."""
    method: str = "SLERP"
    tolerance: float = 0.05
    tension: float = 0.0
    continuity: float = 0.0
    bias: float = 0.0
    shortest_path: bool = True
    clamped: bool = True
    subframes: int = 4


def check_settings(settings):
    if settings.method not in METHODS:
        raise FitError("method %r: cannot be fitted (methods: %s)" % (settings.method, ", ".join(METHODS)))
    if not (settings.tolerance > 0) or not math.isfinite(settings.tolerance):
        raise FitError("tolerance %r°: must be a finite angle above 0" % (settings.tolerance,))
    for name in ("tension", "continuity", "bias"):
        value = getattr(settings, name)
        if not (-1.0 <= value <= 1.0):
            raise FitError("%s %r: must be within -1..1" % (name, value))
    if not (1 <= int(settings.subframes) <= 64) or int(settings.subframes) != settings.subframes:
        raise FitError("subframes %r: must be a whole number from 1 to 64" % (settings.subframes,))


def curve_options(settings, ease_in=None, ease_out=None, turns=None):
    """Keyword options of quatcurve.Curve for the settings' method (and per-key ease and turns)."""
    options = methods.options(settings.method, settings)
    if ease_in is not None and _any(ease_in):
        options["ease_in"] = np.asarray(ease_in, dtype=np.float64)
    if ease_out is not None and _any(ease_out):
        options["ease_out"] = np.asarray(ease_out, dtype=np.float64)
    if turns is not None and _any(turns):
        options["turns"] = np.asarray(turns, dtype=np.float64)
    return options


def _any(values):
    """np.any(values), without its dispatch for an array (a refit asks five times per target)."""
    return bool(values.any()) if isinstance(values, np.ndarray) else bool(np.any(values))


# ---- records on the action: fitted targets and per-key ease -----------------------------------------

def target_key(target):
    """(slot, owner path): what identifies a target's rotation channels inside its action. Inside
    record_index() each target's is found once (a refit asks up to nine times per target)."""
    memo = _target_keys
    if memo is not None:
        at = (target.object.as_pointer(), target.bone)
        key = memo.get(at)
        if key is None:
            key = memo[at] = _target_key(target)
        return key
    return _target_key(target)


def _target_key(target):
    owner = target.owner
    path = owner.path_from_id() if target.bone is not None else ""
    return fcurves.slot_identifier(target.id_data) or "", path


# action pointer → (record count, {(slot, owner path): index of its first record}), inside record_index() only.
_record_index = None
# Also inside record_index() only: (object pointer, bone) → target_key, and the rotation channels
# write_plan wrote, as (action name, slot, data path) (channels written twice in a block — two objects
# playing one action's channels — are not compared with what their read found: that read is no
# longer what they hold).
_target_keys = None
_written = None
# Also inside record_index() only: (action name, slot, data path) → the rotation F-curves
# read_animator_keys found there, taken by the target's write_plan (F-curves are only added inside
# the block, never removed: a reference found stays valid).
_found = None
# The last fit written for each target, by (action name, slot, owner path): the next fit of the same
# target reuses its unchanged key segments (native fit_through_keys' previous). Memory only, cleared
# when a file loads; the native side checks every reused segment against the new keys and curve, so
# an entry that no longer matches the F-curves (an undo, a renamed action) costs reuse, never truth.
# The fits least recently written go first once they hold more than _LAST_FITS_SAMPLES samples (a fit
# keeps ~16 bytes per sample: a 1,000-frame target at 4 subframes ~64 KB).
_last_fits = {}
_last_fit_samples = {}
_LAST_FITS_SAMPLES = 4_000_000


def last_fit(action, target):
    """The native KeyFit last written for `target` in `action`, or None."""
    return _last_fits.get((action.name,) + target_key(target)) if action is not None else None


def forget_fits():
    _last_fits.clear()
    _last_fit_samples.clear()


def _remember_fit(key, kf, samples):
    """Keeps kf as the last fit of `key`, the newest; drops the oldest over _LAST_FITS_SAMPLES."""
    _forget_fit(key)
    _last_fits[key], _last_fit_samples[key] = kf, samples
    _last_fit_samples[None] = _last_fit_samples.get(None, 0) + samples  # None: the total
    while _last_fit_samples[None] > _LAST_FITS_SAMPLES and len(_last_fits) > 1:
        _forget_fit(next(iter(_last_fits)))


def _forget_fit(key):
    _last_fits.pop(key, None)
    if key in _last_fit_samples:
        _last_fit_samples[None] -= _last_fit_samples.pop(key)


@contextlib.contextmanager
def record_index():
    """Within the block find_record finds records through an index of each action's records, built by
    one pass over them on first use, instead of a pass per call (a refit of 100 targets asks twice per
    target: 26 µs each). Inside the block only store_record may change records (it adds; slots and
    owner paths never change); the index is made again when the action's record count changes, and
    a record found must still carry the target's slot and path. Main thread only, like all bpy use."""
    global _record_index, _target_keys, _written, _found
    outer = _record_index
    if outer is None:
        _record_index, _target_keys, _written, _found = {}, {}, set(), {}
    try:
        yield
    finally:
        if outer is None:
            _record_index = _target_keys = _written = _found = None


def find_record(action, target):
    """The fit record of `target` in `action` (the first one, in the unlikely case of two), or None."""
    slot, path = target_key(target)
    records = getattr(action, "quatcurve_fits", ())
    index = _record_index
    if index is not None and len(records):
        count = len(records)
        known = index.get(action.as_pointer())
        if known is None or known[0] != count:
            known = index[action.as_pointer()] = (count, _index_records(records))
        i = known[1].get((slot, path))
        if i is None:
            return None
        record = records[i]
        if record.owner_path == path and record.slot == slot:
            return record
        del index[action.as_pointer()]  # cannot happen within the block's rules: scan, as without it
    for record in records:
        if record.owner_path == path and record.slot == slot:
            return record
    return None


def _index_records(records):
    found = {}
    for i, record in enumerate(records):
        found.setdefault((record.slot, record.owner_path), i)
    return found


def key_eases(action, target, frames):
    """(ease_in, ease_out) arrays for the key `frames` from the action's ease records (0 where none)."""
    slot, path = target_key(target)
    ease_in, ease_out = np.zeros(len(frames)), np.zeros(len(frames))
    for item in getattr(action, "quatcurve_eases", ()):
        if item.owner_path != path or item.slot != slot:
            continue
        k = np.flatnonzero(np.abs(frames - item.frame) < 1e-4)
        if k.size:
            ease_in[k[0]], ease_out[k[0]] = item.ease_in, item.ease_out
    return ease_in, ease_out


def set_key_eases(action, target, frames, ease_in, ease_out):
    """Replaces the target's ease records by one per key frame with a non-zero ease."""
    items = action.quatcurve_eases
    if not len(items) and not (_any(ease_in) or _any(ease_out)):
        return  # nothing stored, nothing to store
    slot, path = target_key(target)
    for i in reversed(range(len(items))):
        if items[i].owner_path == path and items[i].slot == slot:
            items.remove(i)
    n = min(len(frames), len(ease_in), len(ease_out))
    for k in np.flatnonzero((np.asarray(ease_in[:n]) != 0) | (np.asarray(ease_out[:n]) != 0)):
        f, a, b = frames[k], ease_in[k], ease_out[k]
        item = items.add()
        item.slot, item.owner_path, item.frame, item.ease_in, item.ease_out = slot, path, float(f), a, b


def carry_eases(old_frames, new_frames, ease_in, ease_out):
    """Eases of `old_frames` carried to `new_frames`: by frame where a frame stayed, else by order when
    the keys are as many as before (a key moved in time keeps its ease)."""
    old_frames, new_frames = np.asarray(old_frames, float), np.asarray(new_frames, float)
    out_in, out_out = np.zeros(len(new_frames)), np.zeros(len(new_frames))
    if len(old_frames) == len(new_frames):
        return np.asarray(ease_in, float).copy(), np.asarray(ease_out, float).copy()
    for k, f in enumerate(new_frames):
        j = np.flatnonzero(np.abs(old_frames - f) < 1e-4)
        if j.size:
            out_in[k], out_out[k] = ease_in[j[0]], ease_out[j[0]]
    return out_in, out_out


# ---- per-key turns -----------------------------------------------------------------------------------
# Full turns of the segment leaving a key (quaternion targets): Action.quatcurve_turns, by frame, as
# the eases; the curve turns (quatcurve.Curve(turns=...)) and the fit inserts the keys Blender needs
# to play it.

def key_turns(action, target, frames):
    """The turns of the key `frames` from the action's turn records (0 where none)."""
    slot, path = target_key(target)
    turns = np.zeros(len(frames))
    for item in getattr(action, "quatcurve_turns", ()):
        if item.owner_path == path and item.slot == slot:
            k = np.flatnonzero(np.abs(np.asarray(frames) - item.frame) < 1e-4)
            if k.size:
                turns[k[0]] = item.turns
    return turns


def set_key_turns(action, target, frames, turns):
    """Replaces the target's turn records by one per key frame with non-zero turns."""
    items = getattr(action, "quatcurve_turns", None)
    if items is None or (not len(items) and (turns is None or not _any(turns))):
        return
    slot, path = target_key(target)
    for i in reversed(range(len(items))):
        if items[i].owner_path == path and items[i].slot == slot:
            items.remove(i)
    if turns is None:
        return
    for k in np.flatnonzero(np.asarray(turns[:len(frames)]) != 0):
        item = items.add()
        item.slot, item.owner_path, item.frame, item.turns = slot, path, float(frames[k]), int(turns[k])


def turns_message(message, frames):
    """The native curve's message about turns with key indices given as frames."""
    if not message.startswith("turns["):
        return message
    return re.sub(r"\bkey (\d+)", lambda m: "the key at frame %s" % targets.num(frames[int(m.group(1))])
                  if int(m.group(1)) < len(frames) else m.group(0), message)


def axis_angle_turns(values, chosen, turns):
    """Axis-angle key values (K, 4) whose segment leaving each `chosen` key turns `turns` extra full
    turns: axis-angle keys carry their turns in the angle channel (90° → 450° turns once more), so the
    angle change of such a segment becomes its change reduced to (-180°, 180°] plus turns × 360° in the
    direction it turns (-1 on a 90° segment: 270° back), and every later key's angle moves by the same
    whole number of turns. Each key keeps its rotation (a whole turn more about its own axis), and
    every other segment keeps its change. Returns the new values (a copy)."""
    out = np.array(values, dtype=np.float64)
    for k in np.flatnonzero(chosen[:-1]):
        delta = out[k + 1, 0] - out[k, 0]
        base = delta - 2 * math.pi * round(delta / (2 * math.pi))
        if base <= -math.pi:
            base += 2 * math.pi
        direction = -1.0 if base < 0 else 1.0
        out[k + 1:, 0] += base + 2 * math.pi * turns * direction - delta
    return out


def set_turns(found, turns):
    """Sets the turns of the segment leaving each selected animator key of each fitted quaternion or
    axis-angle target and refits it with its settings and eases (the last key has no segment: its
    selection is ignored). Quaternion targets store the turns per key (Action.quatcurve_turns);
    axis-angle targets hold them in their angle keys (axis_angle_turns: the later keys' angles move by
    whole turns, each key the same rotation). Returns a RefitResult (the keys set; each refit's bound
    and notes). Raises FitError naming target and key frame (Euler targets, targets not fitted, no
    selected key, a still segment without an axis to turn about) before anything is written."""
    if not math.isfinite(turns) or int(turns) != turns or abs(turns) > 10000:
        raise FitError("turns %r: must be a whole number from -10000 to 10000" % (turns,))
    plans, changed = [], 0
    with record_index():
        for target in found:
            keys = read_animator_keys(target)
            if keys.is_euler:
                raise FitError("%s: rotation mode %s: Euler keys already keep their turns (key the angle: 0° → 450° "
                               "turns once more); turns are for quaternion keys" % (keys.name, keys.mode))
            record = find_record(fcurves.active_action(target.id_data), target)
            if record is None:
                raise FitError("%s: not fitted (fit it first: turns are part of the fit)" % keys.name)
            chosen = keys.selected.any(axis=0)
            chosen[-1:] = False
            if not chosen.any():
                continue
            ease_in, ease_out, old = refit_eases(keys, target, record)
            changed += int(chosen.sum())
            if keys.is_axis_angle:
                keys = replace(keys, values=axis_angle_turns(keys.values, chosen, turns))
                plan = plan_target(keys, settings_of(record), ease_in, ease_out, old,
                                   previous=last_fit(fcurves.active_action(target.id_data), target))
            else:
                new = old.copy()
                new[chosen] = turns
                plan = plan_target(keys, settings_of(record), ease_in, ease_out, new,
                                   previous=last_fit(fcurves.active_action(target.id_data), target))
            if plan is not None:
                plans.append((plan, target))
        if not plans:
            raise FitError("no selected rotation key with a segment after it on a fitted target (select the key "
                           "that starts the segment to turn)")
        for plan, target in plans:
            write_plan(plan, target)
    return RefitResult("%+d turn%s" % (turns, "" if abs(turns) == 1 else "s"), changed, [p for p, _ in plans])


@dataclass
class RefitResult:
    """What set_turns and set_ease did: the keys they changed and the refit of each target (the
    bound it proved at every instant, its notes), reported as a fit's are."""
    what: str                 # '+2 turns', 'Ease in 0.50 / out 0.00'
    changed: int
    plans: list               # FitPlan per refitted target

    def targets(self):
        return [(TargetResult(p.keys.name, p.keys.mode, len(p.keys.frames), p.generated_count,
                              math.degrees(p.max_error), notes=p.notes), p.settings.tolerance) for p in self.plans]

    def above(self):
        return [t.name for t, tolerance in self.targets() if t.max_error_deg > tolerance]

    def summary(self):
        rows = self.targets()
        above = self.above()
        return "%s on %d key%s, refit %d target%s: max error %.4f°%s" % (
            self.what, self.changed, "" if self.changed == 1 else "s", len(rows), "" if len(rows) == 1 else "s",
            max([t.max_error_deg for t, _ in rows] or [0.0]),
            " — ABOVE the tolerance on %s (see the fit's lines)" % ", ".join(above) if above else "")

    def lines(self):
        rows = self.targets()
        return [t.line(tolerance) for t, tolerance in rows] + [n for t, _ in rows for n in t.notes]


# ---- reading the animator's keys ---------------------------------------------------------------------

@dataclass(eq=False)
class AnimatorKeys:
    """A target's own rotation keys (every key not marked as generated), as plain arrays: planning
    runs on worker threads and never sees Blender data.

    name: the target's name (for messages); mode, prop, path: its rotation mode, property and F-curve
    data path; frames (K,): the union of the channels' animator key frames (channels keyed separately,
    e.g. with "Only Insert Needed", are filled with Blender's evaluation there); values (K, C); types
    (K,) raw keyframe types; selected (C, K) bool: the animator's selection, kept through the refit;
    loop: the cycles.Loop Blender plays the channels as (their Cycles modifiers), None when open.
    stored: what the rotation F-curves held when read, when every channel has one with as many keys
    (fcurves.read_keys_together: co (C, 2N) float32, types (C, N), selected (C, N), generated keys
    too, in stored order), else None: write_plan leaves what is already there as it is (not part of
    the signature)."""
    name: str
    mode: str
    prop: str
    path: str
    frames: np.ndarray
    values: np.ndarray
    types: np.ndarray
    selected: np.ndarray
    loop: cycles.Loop = None
    stored: list = None

    @property
    def is_euler(self):
        return self.mode in fcurves.EULER_ORDERS

    @property
    def is_axis_angle(self):
        return self.mode == "AXIS_ANGLE"

    def signature(self):
        """A digest of the animator's keys (frames, values, types): live mode refits when it changes.
        Computed once (live compares it, store_record stores it): the arrays are not changed in place."""
        known = self.__dict__.get("_signature")
        if known is not None:
            return known
        h = hashlib.sha256(("%s %s" % (self.mode, self.path)).encode())
        if self.loop is not None:  # adding or removing the Cycles modifiers refits (or stops)
            h.update(("loop %r %r %d" % (self.loop.start, self.loop.end, self.loop.offset)).encode())
        for a in (self.frames, self.values, self.types):
            h.update(np.ascontiguousarray(a).tobytes())
        self._signature = h.hexdigest()
        return self._signature


def read_animator_keys(target, curves=None, read=None):
    """AnimatorKeys of `target` in its current rotation mode, from its active action, with the loop its
    Cycles modifiers make (cycles.target_loop). Raises FitError (naming target, channel and frame)
    for no active action, no rotation keys, F-curve modifiers other than a loop's Cycles (naming the
    modifier), a loop whose ends are not animator keys or whose Repeat with Offset is not whole turns,
    NaN/infinite keys, two different keys on one frame, drivers, protected data.

    curves, read: the target's rotation F-curves in its active action and their
    fcurves.read_co_types, when the caller just read them (live mode's raw digest): they are not
    looked up and read again. Inside record_index() the F-curves found are kept for write_plan."""
    try:
        targets.check_editable(target, new_action=False)
    except TargetError as e:
        raise FitError(str(e)) from None
    owner = target.owner
    mode = owner.rotation_mode
    prop, count = fcurves.rotation_property(mode)
    path = owner.path_from_id(prop)
    anim = target.id_data.animation_data
    try:
        if anim is not None and len(anim.drivers):
            targets.refuse_drivers(target, prop, count)
    except TargetError as e:
        raise FitError(str(e)) from None
    action = fcurves.active_action(target.id_data)
    if action is None:
        strips = fcurves.nla_strips(target.id_data)
        raise FitError("%s: no active action%s: fit works on the action the target plays (enter tweak "
                       "mode on the strip, or make its action active)"
                       % (target.name, " (only NLA strips)" if strips else ""))
    if curves is None:
        channels = fcurves.Channels.of(target.id_data)
        curves = channels.find_all(path, count) if channels is not None else [None] * count
    if _found is not None:
        _found[(action.name, target_key(target)[0], path)] = curves
    try:
        loop = cycles.target_loop(target.name, prop, curves, mode, action)
    except TargetError as e:
        raise FitError(str(e)) from None
    if loop is None:
        keys = _keys_together(target.name, mode, prop, path, fcurves.read_keys_together(curves, read))
        if keys is not None:
            return keys
    per_channel = []
    for c, curve in enumerate(curves):
        if curve is None or not fcurves.key_count(curve):
            per_channel.append(None)
            continue
        frames, values = fcurves.read_keys(curve)
        types = fcurves.read_key_types(curve)
        selected = fcurves.read_key_selection(curve)
        mine = types != KEY_TYPE_GENERATED
        if not mine.all():
            frames, values, types, selected = frames[mine], values[mine], types[mine], selected[mine]
        if not len(frames):  # only generated keys: no pose of the animator's on this channel
            per_channel.append((frames, values, types, selected, False))
            continue
        # Keys in strictly increasing frames from a finite one (as Blender keeps them: no NaN among
        # them) need no sort and hold no two on one frame: the stable sort and the duplicate pass
        # below would leave them as they are.
        increasing = bool(len(frames) and np.isfinite(frames[0]) and (frames[1:] > frames[:-1]).all())
        if not increasing:
            order = np.argsort(frames, kind="stable")
            frames, values, types, selected = frames[order], values[order], types[order], selected[order]
        bad = ~np.isfinite(values)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise FitError("%s: %s[%d] is %s at frame %s" % (target.name, prop, c, values[k], targets.num(frames[k])))
        if not increasing:
            same = np.flatnonzero(frames[1:] == frames[:-1])
            for k in same:
                if values[k] != values[k + 1]:
                    raise FitError("%s: %s[%d] has two different keys on frame %s (%s and %s)" % (
                        target.name, prop, c, targets.num(frames[k]), targets.num(round(float(values[k]), 6)),
                        targets.num(round(float(values[k + 1]), 6))))
            keep = np.r_[True, frames[1:] != frames[:-1]]
            frames, values, types, selected = frames[keep], values[keep], types[keep], selected[keep]
        per_channel.append((frames, values, types, selected, increasing))
    keyed = [p for p in per_channel if p is not None]
    if not keyed:
        raise FitError("%s: no rotation keys on %s (rotation mode %s)" % (target.name, prop, mode))
    if not any(len(p[0]) for p in keyed):
        raise FitError("%s: no animator keys on %s: only keys a fit generated are left, and there is no "
                       "pose to fit through (key a pose, or Unmark Fitted Rotation to keep them as they are)"
                       % (target.name, prop))
    first = keyed[0][0]
    if all(p[4] for p in keyed) and all(p[0].tobytes() == first.tobytes() for p in keyed[1:]):
        frames = np.array(first)  # channels keyed together (the usual case): np.unique's answer
    else:
        frames = np.unique(np.concatenate([p[0] for p in keyed]))
    K = len(frames)
    values = np.empty((K, count))
    types = np.full(K, -1, dtype=np.int64)
    selected = np.zeros((count, K), dtype=bool)
    current = getattr(target.owner, prop)
    for c, p in enumerate(per_channel):
        if p is None:
            values[:, c] = current[c]
            continue
        if p[4] and len(p[0]) == K:  # K increasing frames among the K of the union: all of them
            values[:, c] = p[1]
            selected[c] = p[3]
            unset = types < 0
            types[unset] = p[2][unset]
            continue
        where = np.searchsorted(frames, p[0])
        own = np.zeros(K, dtype=bool)
        own[where] = True
        values[where, c] = p[1]
        selected[c, where] = p[3]
        fill = np.flatnonzero(types[where] < 0)
        types[where[fill]] = p[2][fill]
        if (~own).any():  # this channel has no key of its own there: Blender's evaluation
            values[~own, c] = fcurves.evaluate(curves[c], frames[~own])
    types[types < 0] = KEY_TYPE_KEYFRAME
    if loop is not None:
        check_loop(target.name, prop, curves, loop, frames, values)
    return AnimatorKeys(target.name, mode, prop, path, frames, values, types, selected, loop)


def _keys_together(name, mode, prop, path, together):
    """The AnimatorKeys of channels read together (fcurves.read_keys_together) when they are what
    read_animator_keys' general path reads in the usual case — every channel holds the same frames
    and marks the same keys generated, the animator's frames strictly increase from a finite one,
    their values are finite — and so come out the same, in a few operations over all channels at
    once; None otherwise (the general path then reads, fills, sorts or refuses)."""
    if together is None:
        return None
    co, types_all, selected_all = together
    frames_all, values_all = co[:, 0::2].astype(np.float64), co[:, 1::2].astype(np.float64)
    mine_all = types_all != KEY_TYPE_GENERATED
    mine = mine_all[0]
    if not (mine_all == mine).all() or not (frames_all == frames_all[0]).all():
        return None
    frames = frames_all[0][mine]
    values = np.ascontiguousarray(values_all[:, mine].T)
    if not len(frames) or not np.isfinite(frames[0]) or not (frames[1:] > frames[:-1]).all():
        return None
    if not np.isfinite(values).all():
        return None
    return AnimatorKeys(name, mode, prop, path, frames, values, types_all[0][mine], selected_all[:, mine], None,
                        together)


def check_loop(name, prop, curves, loop, frames, values):
    """A loop's period runs from the animator's first key to its last (a generated key never ends
    it), and a channel repeating with offset moves by whole turns per period (Euler angles, the
    axis-angle angle) or not at all (the axis), so that each period plays the same rotations. Raises
    FitError naming the channel."""
    if frames[0] != loop.start or frames[-1] != loop.end:
        raise FitError("%s: %s loops over frames %s–%s, but the animator's keys span %s–%s: key the loop's "
                       "first and last frames" % (name, prop, targets.num(loop.start), targets.num(loop.end),
                                                  targets.num(frames[0]), targets.num(frames[-1])))
    if not loop.offset:
        return
    angle_channels = range(3) if len(values[0]) == 3 else (0,)
    for c, curve in enumerate(curves):
        if curve is None or not len(curve.modifiers) or cycles.channel_cycle(curve)[0] != "REPEAT_OFFSET":
            continue
        step = float(values[-1, c] - values[0, c])
        turns = step / (2 * math.pi) if c in angle_channels else 0.0
        if abs(step - 2 * math.pi * round(turns)) > 1e-4:
            what = ("%.4g° per period, not whole turns" % math.degrees(step) if c in angle_channels else
                    "%.6g per period (an axis channel's offset changes the axis each period)" % step)
            raise FitError("%s: %s[%d] repeats with offset %s: each period would play other rotations; key the "
                           "last key whole turns from the first, or use Repeat" % (name, prop, c, what))


# ---- the fit ------------------------------------------------------------------------------------------

@dataclass(eq=False)
class FitPlan:
    """What fit writes for one target: per channel (frames, values, handle_left, handle_right, types),
    the selection of the animator's keys, and the figures the report gives."""
    keys: AnimatorKeys
    settings: FitSettings
    channels: list
    max_error: float          # radians: proved bound of Blender's playback (emulated) against the method at every instant
    animator_count: int
    generated_count: int
    samples: int
    ease_in: np.ndarray
    ease_out: np.ndarray
    notes: list = field(default_factory=list)
    turns: np.ndarray = None
    fit: object = None        # the native KeyFit (the next refit's `previous`)
    synchronized: bool = False  # every channel has the same key frames and types


def path_notes(name, curve, frames, method):
    """One note per key segment whose path breaks the path rule (path_rule.breaks): the target, the
    frames and the ratio. Clamped methods never do; SPLINE_C2 may."""
    return ["path rule: " + b.text() for b in path_rule.breaks(curve, frames, name, method)]


def curve_of(keys, settings, ease_in=None, ease_out=None, turns=None):
    """The native curve of the settings' method through the animator's keys, and the key values the
    fit writes (quaternion signs made to follow the curve; Euler and axis-angle keys as they are,
    their turns kept by the curve)."""
    options = curve_options(settings, ease_in, ease_out, turns)
    if keys.loop is not None:
        options["cyclic"] = True
    try:
        curve = targets.build_curve(keys.mode, keys.frames, keys.values, settings.method, keys.name, **options)
    except TargetError as e:
        raise FitError(str(e)) from None
    except ValueError as e:
        raise FitError("%s: %s" % (keys.name, turns_message(str(e), keys.frames))) from None
    if keys.is_euler or keys.is_axis_angle:
        return curve, keys.values  # their turns are kept by the curve
    # The curve's output is sign-continuous; each key takes the sign the curve reaches it with.
    at_keys = curve.sample(keys.frames)
    signs = np.where(np.sum(at_keys * keys.values, axis=1) < 0, -1.0, 1.0)
    return curve, keys.values * signs[:, None]


def plan_target(keys, settings, ease_in=None, ease_out=None, turns=None, previous=None):
    """The fitted keys of one target (nothing written). Fewer than two keys: None. previous: the
    target's last KeyFit (last_fit), whose unchanged key segments are kept."""
    fitted = fit_target(keys, settings, ease_in, ease_out, turns, previous)
    return None if fitted is None else plan_of(fitted)


def fit_target(keys, settings, ease_in=None, ease_out=None, turns=None, previous=None):
    """plan_target's native fit: (keys, settings, KeyFit, ease_in, ease_out, turns), for plan_of; None
    for fewer than two keys. Raises FitError."""
    job = fit_job(keys, settings, ease_in, ease_out, turns)
    if job is None:
        return None
    options, used = job
    # One native call without the GIL (quatcurve.fit_channels): the curve as curve_of builds it, the
    # key signs it reaches them with, samples, channel values joining the keys as keyed, fit_keys, and
    # the proof of the bound at every instant (KeyFit.proof).
    try:
        kf = native.require().fit_channels(keys.frames, keys.values, keys.mode, settings.method, previous=previous,
                                           **options)
    except ValueError as e:
        raise fit_error(keys, e) from None
    return (keys, settings, kf) + used


def fit_job(keys, settings, ease_in=None, ease_out=None, turns=None):
    """fit_target's native call without its keys: (the keyword arguments of quatcurve.fit_channels
    after key frames, values, mode and method — FitQueue.push takes the same —, (ease_in, ease_out,
    turns) as the fit uses them); None for fewer than two keys."""
    K = len(keys.frames)
    if K < 2:
        return None
    ease_in = np.zeros(K) if ease_in is None else np.asarray(ease_in, float)
    ease_out = np.zeros(K) if ease_out is None else np.asarray(ease_out, float)
    # Turns are for quaternion keys: Euler and axis-angle keys carry their turns in their angles, and
    # their channels, kept as keyed at the keys, could not add one (a target whose mode changed since
    # its turns were set plays its keys' own turns).
    if turns is None or keys.mode != "QUATERNION":
        turns = np.zeros(K)
    turns = np.asarray(turns, float)
    if keys.loop is not None:
        ease_in, ease_out = seam_eases(ease_in, ease_out)
    options = curve_options(settings, ease_in, ease_out, turns)
    if keys.loop is not None:
        options["cyclic"] = True
    options.update(subframes=int(settings.subframes), tolerance=math.radians(settings.tolerance),
                   min_gap=MIN_KEY_GAP)
    return options, (ease_in, ease_out, turns)


def fit_error(keys, error):
    """The FitError of a native fit's ValueError, naming the target (and the frame of a zero
    quaternion or axis: curve_of's message)."""
    try:
        targets.refuse_zero_rotations(keys.mode, keys.values, keys.name, keys.frames)
    except TargetError as zero:
        return FitError(str(zero))
    return FitError("%s: %s" % (keys.name, turns_message(str(error), keys.frames)))


def plan_of(fitted):
    """The FitPlan of fit_target's result: each channel's keys with their types (the animator's keys'
    own, GENERATED for the inserted ones), the figures and the notes."""
    keys, settings, kf, ease_in, ease_out, turns = fitted
    K = len(keys.frames)
    forced, fitted = kf.forced, kf.keys
    notes = euler_notes(keys, kf)
    channels, generated, synchronized = [], 0, False
    shared = None  # (indices, types, generated) of the channel before: synchronized channels share them
    chans = fitted.channels
    if fitted.synchronized and chans:  # every channel has the same key indices: their types are found once
        indices = chans[0].indices
        types = np.full(len(indices), KEY_TYPE_GENERATED, dtype=np.int64)
        at = np.searchsorted(forced, indices)
        is_key = (at < K) & (forced[np.minimum(at, K - 1)] == indices)
        types[is_key] = keys.types[at[is_key]]
        generated = (len(indices) - int(np.count_nonzero(is_key))) * len(chans)
        channels = [(ch.frames, ch.values, ch.handle_left, ch.handle_right, types.copy()) for ch in chans]
        chans, synchronized = (), True
    for ch in chans:
        indices = ch.indices
        if shared is not None and np.array_equal(shared[0], indices):
            types = shared[1].copy()
        else:
            types = np.full(len(indices), KEY_TYPE_GENERATED, dtype=np.int64)
            at = np.searchsorted(forced, indices)
            is_key = (at < K) & (forced[np.minimum(at, K - 1)] == indices)
            types[is_key] = keys.types[at[is_key]]
            shared = (indices, types.copy(), len(indices) - int(np.count_nonzero(is_key)))
        generated += shared[2]
        channels.append((ch.frames, ch.values, ch.handle_left, ch.handle_right, types))
    proof = kf.proof
    if not proof.proven:
        notes.append("%s: the bound holds within %.4f° at every instant, ABOVE the tolerance near frame %.3f%s" % (
            keys.name, math.degrees(proof.bound), proof.worst_time, _above_cause(keys, kf, channels, proof.worst_time)))
    # The samples (kf.times, a copy when asked for): the last key is the last of them.
    return FitPlan(keys, settings, channels, proof.bound, K * len(channels), generated, int(forced[-1]) + 1,
                   ease_in, ease_out, notes + path_notes(keys.name, kf.curve, keys.frames, settings.method), turns, kf,
                   synchronized)


# Blender plays a key's own value at frames within this of the key (its evaluation snaps to the key);
# the proof evaluates both edges of that zone (docs/curves.md, "A bound at every instant").
KEY_SNAP = 1e-4


def _above_cause(keys, kf, channels, worst):
    """Why a fit's bound stays above the tolerance near frame `worst`, for its note: a change of
    Euler branch or of the angle's turn; Blender's snap to a key (a key written within KEY_SNAP of
    `worst` on a channel moving so fast there that the snap's step, added to the fit's own error,
    passes the tolerance: named with the step); else keys closer than MIN_KEY_GAP would be needed."""
    if len(kf.switches):
        return (" (a change of the angle's turn: convert the target to quaternion for the method's exact path)"
                if keys.is_axis_angle else
                " (a change of Euler branch: convert the target to quaternion for the method's exact path)")
    best = None  # (step in degrees, channel, key frame)
    for c, (frames, values, left, right, _) in enumerate(channels):
        frames = np.asarray(frames, float)
        for k in np.flatnonzero(np.abs(frames - worst) <= 1.5 * KEY_SNAP):
            slopes = [(v - values[k]) / (f - frames[k]) for f, v in (left[k], right[k]) if f != frames[k]]
            rate = max((abs(x) for x in slopes), default=0.0)  # per frame, in the channel's units
            if keys.mode == "QUATERNION":
                rate *= 2.0  # a unit quaternion's channel turns the rotation by up to twice its change
            elif keys.is_axis_angle and c > 0:
                continue  # an axis channel's change turns the rotation by sin(θ/2) of it: not a step in degrees
            step = math.degrees(rate * KEY_SNAP)
            if best is None or step > best[0]:
                best = (step, c, float(frames[k]))
    if best is not None:
        return (" (Blender plays %s[%d]'s key at frame %.5f for every frame within %g of it; that channel moves "
                "fast there, and the step, about %.3f°, adds to the fit's own error)"
                % (keys.prop, best[1], best[2], KEY_SNAP, best[0]))
    return " (keys closer than %g frames would be needed)" % MIN_KEY_GAP


def seam_eases(ease_in, ease_out):
    """A loop's first and last keys are one key, the seam: the motion comes into it through the last
    key and leaves it through the first. An ease set on either end applies at the seam: the first
    key's ease in becomes the last key's (where that has none), the last key's ease out the first's."""
    ease_in, ease_out = np.array(ease_in, float), np.array(ease_out, float)
    if ease_in[-1] == 0:
        ease_in[-1] = ease_in[0]
    if ease_out[0] == 0:
        ease_out[0] = ease_out[-1]
    ease_in[0], ease_out[-1] = ease_in[-1], ease_out[0]
    return ease_in, ease_out


def euler_notes(keys, kf):
    """Where the channels change representation between keys, one note each: Euler channels change
    branch (beside a key at gimbal lock, or nearest the lock); axis-angle channels change to another
    turn of the angle where the path passes nearest the rest pose."""
    change = ("the angle changes turn where the rotation passes nearest the rest pose" if keys.is_axis_angle else
              "the channels change Euler branch")
    what = "another turn of its angle" if keys.is_axis_angle else "another Euler branch"
    return ["%s: between the keys at frames %g and %g the method's path reaches the second key on %s; %s, "
            "at frame %.3f" % (keys.name, keys.frames[segment], keys.frames[segment + 1], what, change, frame)
            for segment, frame in kf.switches]


def write_plan(plan, target):
    """Writes one target's fitted keys into its active action, in place: the rotation F-curves' keys
    are replaced by the animator's keys (same frames and values, fitted FREE handles, their types and
    selection kept) and the generated keys; then the fit record and the eases are stored.

    A refit mostly changes a few key segments: where the F-curves still hold, key for key, the types
    and selection this fit writes (as their read found them, `keys.stored`), their keys are kept and
    their frames and values written only where they changed (_rewrite_kept); either way the
    F-curves end up holding exactly the fitted keys, with BEZIER interpolation and FREE handles."""
    keys = plan.keys
    action = fcurves.active_action(target.id_data)
    where = (action.name, target_key(target)[0], keys.path)
    found = _found.pop(where, None) if _found is not None else None
    channels = None
    if found is None or len(found) != len(plan.channels) or any(curve is None for curve in found):
        channels = fcurves.Channels.of(target.id_data, action, create=True)
        found = channels.find_all(keys.path, len(plan.channels))
    if _rewrite_kept(plan, found, where):
        action.update_tag()  # foreach_set tags nothing: the action's evaluated copy must be made again
    else:
        if channels is None:
            channels = fcurves.Channels.of(target.id_data, action, create=True)
        group = False  # the group of the channels' F-curves, read when a missing one is made
        for c, (frames, values, left, right, types) in enumerate(plan.channels):
            curve = found[c]
            if curve is None:
                if group is False:
                    group = channels.group_of(keys.path)
                curve = channels.new_fcurve(keys.path, c, group=group)
                if keys.loop is not None:  # every rotation channel of a loop repeats: Blender's plain Cycles
                    curve.modifiers.new("CYCLES")
            fcurves.write_keys(curve, frames, values, interpolation="BEZIER", handle_left=left, handle_right=right)
            fcurves.write_key_types(curve, types)
            chosen = np.zeros(len(frames), dtype=bool)
            at = np.searchsorted(keys.frames, frames)
            on_key = (at < len(keys.frames)) & (keys.frames[np.minimum(at, len(keys.frames) - 1)] == frames)
            chosen[on_key] = keys.selected[c, at[on_key]]
            fcurves.write_key_selection(curve, chosen)
    if _written is not None:
        _written.add(where)
    store_record(keys, plan.settings, target, action, plan.max_error)
    if plan.fit is not None:
        _remember_fit((action.name,) + target_key(target), plan.fit, plan.samples)
    set_key_eases(action, target, keys.frames, plan.ease_in, plan.ease_out)
    set_key_turns(action, target, keys.frames, plan.turns)
    target.id_data.update_tag(refresh={"TIME"})


def _rewrite_kept(plan, curves, where):
    """Writes the plan's channels over `curves` keeping their key slots, when each still holds as many
    keys, with the types and selection the plan gives them, as its read found (`keys.stored`), and
    no earlier write_plan of this record_index() block wrote them (`where`: action name, slot, data
    path): only the frames and values of a
    channel whose keys changed bit for bit, and every channel's interpolation, handle types and
    handles (fcurves.rewrite_handles). All channels at once; False (nothing written) otherwise."""
    keys, chans, written = plan.keys, plan.channels, _written
    if keys.stored is None or written is None or where in written:
        return False
    co_was, types_was, selected_was = keys.stored
    C, n = types_was.shape
    if len(chans) != C or len(curves) != C:
        return False
    for curve in curves:
        if curve is None or len(curve.keyframe_points) != n:
            return False
    if any(len(ch[0]) != n for ch in chans):
        return False
    if plan.synchronized:  # one set of frames and types for every channel (plan_of)
        frames = chans[0][0]
        if not (types_was == chans[0][4]).all():
            return False
    else:
        if not np.array_equal(np.array([ch[4] for ch in chans]), types_was):
            return False
        stacked = np.array([ch[0] for ch in chans])
        if not (stacked == stacked[0]).all():
            return False
        frames = stacked[0]
    if not (frames[1:] > frames[:-1]).all():
        return False
    if n == len(keys.frames) and (frames == keys.frames).all():
        chosen = keys.selected  # no generated key: every key is the animator's
    else:
        at = np.searchsorted(keys.frames, frames)
        on_key = (at < len(keys.frames)) & (keys.frames[np.minimum(at, len(keys.frames) - 1)] == frames)
        chosen = np.zeros((C, n), dtype=bool)
        chosen[:, on_key] = keys.selected[:, at[on_key]]
    if not (chosen == selected_was).all():
        return False
    co = np.empty((C, n, 2), dtype=np.float32)
    co[:, :, 0] = frames
    co[:, :, 1] = [ch[1] for ch in chans]
    co = co.reshape(C, 2 * n)
    changed = (co.view(np.uint32) != co_was.view(np.uint32)).any(axis=1)
    left = np.array([ch[2] for ch in chans], dtype=np.float32).reshape(C, 2 * n)
    right = np.array([ch[3] for ch in chans], dtype=np.float32).reshape(C, 2 * n)
    for c, curve in enumerate(curves):
        fcurves.rewrite_handles(curve, co[c] if changed[c] else None, left[c], right[c])
    return True


def store_record(keys, settings, target, action=None, bound=None):
    """The target's fit record in `action` (default: its active action): method, settings, the
    signature and frames of its animator keys, and the fit's proved bound (radians; None: not known)."""
    if action is None:
        action = fcurves.active_action(target.id_data)
    record = find_record(action, target)
    if record is None:
        records = action.quatcurve_fits
        record = records.add()
        record.slot, record.owner_path = target_key(target)
        known = _record_index.get(action.as_pointer()) if _record_index is not None else None
        if known is not None and known[0] == len(records) - 1:  # the index learns the new record
            known[1].setdefault((record.slot, record.owner_path), len(records) - 1)
            _record_index[action.as_pointer()] = (len(records), known[1])
    # Each property only when it changes (a refit keeps the settings and mostly the frames).
    for name in ("method", "tolerance", "tension", "continuity", "bias", "shortest_path", "clamped", "subframes"):
        value = getattr(settings, name)
        if getattr(record, name) != value:
            setattr(record, name, value)
    if record.prop != keys.prop:
        record.prop = keys.prop
    signature = keys.signature()
    if record.signature != signature:
        record.signature = signature
    frames = np.asarray(keys.frames, dtype=np.float64)
    if not np.array_equal(record_frames(record), frames):
        record.key_frames = " ".join(map(repr, frames.tolist()))
    bound = -1.0 if bound is None else float(bound)
    if record.bound != np.float32(bound):
        record.bound = bound


def settings_of(record):
    """The FitSettings stored in a fit record."""
    return FitSettings(method=record.method, tolerance=record.tolerance, tension=record.tension,
                       continuity=record.continuity, bias=record.bias, shortest_path=record.shortest_path,
                       clamped=record.clamped, subframes=record.subframes)


_record_frames = {}  # record.key_frames text → its frames (read-only), the latest few hundred


def record_frames(record):
    """The key frames a fit record stores (read-only array)."""
    text = record.key_frames
    frames = _record_frames.get(text)
    if frames is None:
        if len(_record_frames) >= 512:
            _record_frames.clear()
        frames = np.array([float(x) for x in text.split()], dtype=np.float64)
        frames.flags.writeable = False
        _record_frames[text] = frames
    return frames


def refit_eases(keys, target, record=None):
    """The (ease_in, ease_out, turns) of the target's keys from its active action's records; keys
    moved in time since `record` (as many as then) keep their ease and turns. Reads Blender data:
    main thread."""
    action = fcurves.active_action(target.id_data)
    ease_in, ease_out = key_eases(action, target, keys.frames)
    turns = key_turns(action, target, keys.frames)
    if record is not None and record.key_frames:
        old = record_frames(record)
        if len(old) == len(keys.frames) and not np.array_equal(old, keys.frames):
            o_in, o_out = key_eases(action, target, old)
            ease_in, ease_out = carry_eases(old, keys.frames, o_in, o_out)
            turns = carry_eases(old, keys.frames, key_turns(action, target, old), turns)[0]
    return ease_in, ease_out, turns


# ---- the task -------------------------------------------------------------------------------------------

@dataclass
class TargetResult:
    name: str
    mode: str
    animator_keys: int
    generated_keys: int
    max_error_deg: float
    skipped: str = ""
    notes: list = field(default_factory=list)

    def line(self, tolerance):
        if self.skipped:
            return "%s: left as it is (%s)" % (self.name, self.skipped)
        over = "" if self.max_error_deg <= tolerance else " — ABOVE the tolerance: keys too close to insert between"
        return "%s: %s, %d animator keys + %d generated, max error %.4f°%s" % (
            self.name, self.mode, self.animator_keys, self.generated_keys, self.max_error_deg, over)


@dataclass
class FitResult:
    settings: FitSettings
    targets: list = field(default_factory=list)
    seconds: float = 0.0

    @property
    def fitted(self):
        return [t for t in self.targets if not t.skipped]

    def summary(self):
        n = len(self.fitted)
        return "Fitted %d target%s with %s: %d animator + %d generated keys, max error %.4f°, %.2f s" % (
            n, "" if n == 1 else "s", methods.label_and_id(self.settings.method),
            sum(t.animator_keys for t in self.fitted), sum(t.generated_keys for t in self.fitted),
            max([t.max_error_deg for t in self.fitted] or [0.0]), self.seconds)

    def lines(self):
        return [t.line(self.settings.tolerance) for t in self.targets] + [n for t in self.targets for n in t.notes]


def fit(found, settings, only_changed=False):
    """Fits every target (see the module docstring). Reads and plans all targets first, then writes:
    an error leaves everything untouched. A target with fewer than two rotation keys is left as it is
    and named in the result. only_changed: skip targets whose fit record's signature still matches
    (live mode). Raises FitError."""
    check_settings(settings)
    start = time.perf_counter()
    result = FitResult(settings)
    # Blender is read on the main thread; the fits (native curve, sampling, fit_keys and the proof)
    # run on native worker threads (_fit: same results on any count).
    with record_index():
        _fit(found, settings, only_changed, result)
    result.seconds = time.perf_counter() - start
    return result


def _fit(found, settings, only_changed, result):
    # Each target to fit goes to a quatcurve.FitQueue as soon as it is read: its native workers fit it
    # while the main thread reads the next ones; the fits are taken in order, and the first that
    # fails raises before anything is written.
    found = list(found)
    queue = native.require().FitQueue(threads=thread_count() if len(found) > 1 else 0)
    work = []
    for target in found:
        keys = read_animator_keys(target)
        action = fcurves.active_action(target.id_data)
        record = find_record(action, target)
        if only_changed and record is not None and record.signature == keys.signature():
            continue
        job = fit_job(keys, settings, *refit_eases(keys, target, record))
        if job is not None:
            queue.push(keys.frames, keys.values, keys.mode, settings.method, previous=last_fit(action, target),
                       **job[0])
        work.append((target, keys, job))
    queue.close()
    plans = []
    for target, keys, job in work:
        if job is None:
            result.targets.append(TargetResult(keys.name, keys.mode, len(keys.frames), 0, 0.0,
                                               skipped="%d rotation key%s: nothing to fit" % (
                                                   len(keys.frames), "" if len(keys.frames) == 1 else "s")))
            continue
        try:
            kf = next(queue)
        except ValueError as error:
            raise fit_error(keys, error) from None
        plan = plan_of((keys, settings, kf) + job[1])
        plans.append((plan, target))
        result.targets.append(TargetResult(keys.name, keys.mode, len(keys.frames), plan.generated_count,
                                           math.degrees(plan.max_error), notes=plan.notes))
    for plan, target in plans:
        write_plan(plan, target)


def unfit(found):
    """Unmarks the targets: their fit records and eases are removed (keys, handles and generated keys
    stay as they are: the handles are now the animator's). Returns the names unmarked."""
    names = []
    for target in found:
        action = fcurves.active_action(target.id_data)
        record = find_record(action, target) if action is not None else None
        if record is None:
            continue
        action.quatcurve_fits.remove(list(action.quatcurve_fits).index(record))
        _forget_fit((action.name,) + target_key(target))
        set_key_eases(action, target, [], [], [])
        set_key_turns(action, target, [], [])
        names.append(target.name)
    return names


def source_keys(target, action=None):
    """The target's rotation keys as the tasks read them (targets.read_rotation_keys): for a fitted
    target (a fit record in the action) only the animator's key frames — the keys the fit generated
    are its way of making Blender play the method, not poses, so a bake, a comparison or a trail
    builds the method through the animator's keys, as the fit did."""
    where = action if action is not None else fcurves.active_action(target.id_data)
    fitted = where is not None and find_record(where, target) is not None
    return targets.read_rotation_keys(target, action, skip_key_type=KEY_TYPE_GENERATED if fitted else None)


def fitted_targets(action):
    """Every Target whose fit record is in `action` (objects playing it, with the record's slot)."""
    found = []
    records = list(getattr(action, "quatcurve_fits", ()))
    if not records:
        return found
    for obj in fcurves.action_users(action):
        if fcurves.active_action(obj) != action:
            continue
        slot = fcurves.slot_identifier(obj) or ""
        for record in records:
            if record.slot != slot:
                continue
            if record.owner_path == "":
                found.append(targets.Target(obj))
            elif obj.pose is not None and record.owner_path.startswith('pose.bones["'):
                name = record.owner_path[len('pose.bones["'):-2].replace('\\"', '"')
                if name in obj.pose.bones:
                    found.append(targets.Target(obj, name))
    return found
