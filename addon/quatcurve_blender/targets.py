"""Targets: the selection as objects and pose bones, and each target's rotation keys as Blender
evaluates them. The reading layer of the add-on: every task (bake, reduce, compare) starts here.

    targets = targets.gather_targets(bpy.context)     # or [Target(obj), Target(rig, "Bone")]
    keys = targets.read_rotation_keys(targets[0])     # plain arrays: frames, channel values, notes
    played = targets.playback(targets[0])             # Blender's evaluation at any frames (main thread)
    curve = keys.curve("SQUAD")                       # build_curve: every task's curves are made there

The key arrays hold no Blender reference, so the compute step (native curves, sampling, reduction,
fitting) may run on worker threads; what Blender plays between keys is read through a Playback, on
the main thread.

Refused with a TargetError naming object, bone, channel and frame: nothing selected, no rotation
keys in the target's mode, NaN/infinite keys, two different keys on one frame, drivers on rotation,
library-linked or override-protected data. Reading changes nothing (NLA evaluation restores the
scene's frame). F-curves are read through fcurves.py; rotations are built natively (channels_to_quats).
"""

import math
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import fcurves, native


class TargetError(Exception):
    """A target (or selection) that cannot be used; the message names the object, bone, channel and
    frame at fault. Every task's own error (BakeError, CompareError, ReduceError) derives from it."""


def num(x):
    """A number as a person writes it: whole numbers in full (100000000, not 1e+08)."""
    if isinstance(x, (int, float, np.floating, np.integer)):
        x = float(x)
        return "%d" % x if x.is_integer() and abs(x) < 1e16 else "%g" % x
    return repr(x)


# ---- targets ----------------------------------------------------------------------------------------

@dataclass(eq=False)
class Target:
    """An object, or a pose bone of an armature object (`bone` is the pose bone's name)."""
    object: object
    bone: str = None

    @property
    def id_data(self):
        """The ID holding the animation data (the object, also for pose bones)."""
        return self.object

    @property
    def owner(self):
        """The struct with rotation_mode and the rotation properties: the object or the pose bone."""
        return self.object.pose.bones[self.bone] if self.bone is not None else self.object

    @property
    def name(self):
        return "%s/%s" % (self.object.name, self.bone) if self.bone is not None else self.object.name

    def data_path(self, prop):
        """F-curve data path of `prop` ('rotation_euler', …) on this target."""
        return self.owner.path_from_id(prop)


def gather_targets(context, verb="bake"):
    """The selection: selected pose bones in Pose mode, selected objects otherwise; sorted by name.
    Raises TargetError when nothing is selected ("Nothing to <verb>: …")."""
    if context.mode == "POSE":
        bones = list(getattr(context, "selected_pose_bones", None) or [])
        targets = [Target(pb.id_data, pb.name) for pb in bones]
        what = "pose bones selected (Pose mode)"
    else:
        objects = getattr(context, "selected_objects", None)
        if objects is None:
            objects = [o for o in context.view_layer.objects if o.select_get()]
        targets = [Target(o) for o in objects]
        what = "objects selected (Object mode)"
    if not targets:
        raise TargetError("Nothing to %s: no %s" % (verb, what))
    return sorted(targets, key=lambda t: (t.object.name, t.bone or ""))


def has_rotation_animation(target):
    """True when the target's current rotation mode has at least one keyed rotation channel."""
    prop, count = fcurves.rotation_property(target.owner.rotation_mode)
    channels = fcurves.Channels.of(target.id_data)
    return channels is not None and any(
        f is not None and fcurves.key_count(f) for f in channels.find_all(target.data_path(prop), count))


def animated_targets(objects):
    """Every object and pose bone among `objects` with rotation animation in its current mode (the
    CLI's default selection)."""
    found = []
    for obj in sorted(objects, key=lambda o: o.name):
        if obj.type == "ARMATURE" and obj.pose is not None:
            found += [t for t in (Target(obj, pb.name) for pb in obj.pose.bones) if has_rotation_animation(t)]
        if has_rotation_animation(Target(obj)):
            found.append(Target(obj))
    return found


def check_editable(target, new_action):
    """Raises TargetError when the target's data may not be changed (library-linked or overridden)."""
    why = fcurves.is_protected(target.id_data)
    if why:
        raise TargetError("%s: the object is %s and cannot be changed" % (target.name, why))
    action = fcurves.active_action(target.id_data)
    why = fcurves.is_protected(action)
    if why and not new_action:
        raise TargetError("%s: action '%s' is %s and cannot be changed in place" % (target.name, action.name, why))


# ---- reading the source -------------------------------------------------------------------------------

@dataclass(eq=False)
class RotationKeys:
    """A target's rotation keys as plain arrays: what every compute step takes.

    name: the target's name (for messages); mode: the rotation mode read (the target's); prop:
    'rotation_euler' etc.; frames (K,): every frame where any channel of prop is keyed; values (K, 3|4):
    Blender's evaluation of each channel there (an unkeyed channel holds the property's value);
    key_count: the keys on the channels' F-curves; modifiers: per channel, the F-curve modifier types."""
    name: str
    mode: str
    prop: str
    frames: np.ndarray
    values: np.ndarray
    key_count: int = 0
    modifiers: tuple = ()
    notes: list = field(default_factory=list)   # what the bake report should tell the animator
    nla: bool = False                           # values are Blender's NLA-evaluated result

    @property
    def is_euler(self):
        return self.mode in fcurves.EULER_ORDERS

    def quats(self):
        """The keys' orientations (w, x, y, z) as Blender builds them."""
        return channels_to_quats(self.mode, self.values, self.name, self.frames)

    def curve(self, method, **options):
        """The native curve of `method` through these keys (build_curve)."""
        return build_curve(self.mode, self.frames, self.values, method, self.name, **options)

    def bake_job(self, method, mode, reference=None, **options):
        """quatcurve.BakeJob: the curve() of `method` through these keys, to be sampled as the keys of
        rotation mode `mode` (with Curve.sample_keys' `reference`) by a quatcurve.BakeQueue."""
        refuse_zero_rotations(self.mode, self.values, self.name, self.frames)
        return native.require().BakeJob(self.frames, self.values, self.mode, method, mode, reference, **options)


def build_curve(mode, frames, values, method, name="", **options):
    """The native curve of `method` through keys given as channel values of rotation mode `mode`
    (quatcurve.Curve.from_channels: Euler and axis-angle keys keep turns beyond 180° between keys;
    quaternion keys are taken as stored, as QUAT_COMPONENTS lerps them). Every task builds its curves
    here. A zero quaternion or axis-angle axis raises TargetError naming `name` and the frame; the
    native module's ValueError (bad options, key spacing) passes through."""
    refuse_zero_rotations(mode, values, name, frames)
    return native.require().Curve.from_channels(frames, values, mode, method, **options)


class Playback:
    """What Blender plays on a target's rotation channels, read at any frames (main thread only): the
    channels' F-curves evaluated by Blender, or with NLA strips the whole animation (scene.frame_set)."""

    def __init__(self, target, mode, prop, channel_fcurves, nla):
        self.target, self.mode, self.prop = target, mode, prop
        self.fcurves, self.nla = channel_fcurves, nla

    def evaluate(self, frames):
        """(N, 3|4) channel values at `frames`."""
        if self.nla:
            return evaluate_in_scene(self.target, self.prop, frames)
        return evaluate_channels(self.target, self.prop, self.fcurves, frames)

    def quats(self, frames):
        """Blender's orientations (w, x, y, z) at `frames`."""
        return channels_to_quats(self.mode, self.evaluate(frames), self.target.name, frames)


def evaluate_channels(target, prop, channel_fcurves, frames):
    """(N, len(channel_fcurves)) values of target.prop's channels at `frames`: Blender's evaluation of
    each F-curve, or the property's current value for an unkeyed channel."""
    frames = np.asarray(frames, dtype=np.float64)
    current = getattr(target.owner, prop)
    out = np.empty((len(frames), len(channel_fcurves)))
    for i, fcurve in enumerate(channel_fcurves):
        out[:, i] = fcurves.evaluate(fcurve, frames) if fcurve is not None else current[i]
    return out


def evaluate_in_scene(target, prop, frames):
    """(N, C) values of target.prop as the whole animation system plays them at `frames` (NLA strips
    included): scene.frame_set at each frame, then the scene's frame is restored."""
    scene = bpy.context.scene
    current = scene.frame_current, scene.frame_subframe
    out = []
    try:
        for frame in np.asarray(frames, dtype=np.float64):
            whole = math.floor(frame)
            scene.frame_set(int(whole), subframe=float(frame - whole))
            out.append(tuple(getattr(target.owner, prop)))
    finally:
        scene.frame_set(current[0], subframe=current[1])
    return np.array(out, dtype=np.float64).reshape(len(out), -1)


def _rotation_channels(target, action):
    """(mode, prop, channels, keyed F-curves per channel (None: unkeyed), NLA strips playing them)."""
    mode = target.owner.rotation_mode
    prop, count = fcurves.rotation_property(mode)
    path = target.data_path(prop)
    channels = fcurves.Channels.of(target.id_data, action)
    found = channels.find_all(path, count) if channels is not None else [None] * count
    found = [f if f is not None and fcurves.key_count(f) else None for f in found]
    strips = [] if action is not None else [
        strip for strip, strip_channels in fcurves.nla_strips(target.id_data)
        if strip_channels is not None and any(strip_channels.find(path, i) is not None for i in range(count))]
    return mode, prop, channels, found, strips


def playback(target, action=None):
    """The Playback of `target`'s rotation in its current mode, from `action` (default: its active
    action and the NLA strips that play on it)."""
    mode, prop, _, found, strips = _rotation_channels(target, action)
    return Playback(target, mode, prop, found, bool(strips))


def read_rotation_keys(target, action=None, skip_key_type=None):
    """RotationKeys of `target` in its current rotation mode, from `action` (default: its active
    action, and the NLA strips that play on it). skip_key_type: a raw keyframe type whose keys are
    not key frames (a fit's generated keys: fit.source_keys); Blender's evaluation is read at the
    other keys' frames.

    Raises TargetError when the mode's channels have no keys, hold NaN/infinite values, have two keys
    with different values on one frame, or are driven by a driver. Notes (RotationKeys.notes) tell
    what a bake keeps: channels held at their current value, F-curve modifiers read at the keys,
    constraints that still apply, NLA strips whose evaluated result is read at every frame."""
    mode, prop, channels, found, strips = _rotation_channels(target, action)
    refuse_drivers(target, prop, len(found))
    if not any(found) and not strips:
        raise TargetError("%s: no rotation animation (rotation mode %s, no keys on %s)%s"
                        % (target.name, mode, prop, _other_keyed_hint(target, channels, prop)))
    for i, fcurve in enumerate(found):
        if fcurve is not None:
            _refuse_jumps(target, prop, i, fcurve)
    notes = _channel_notes(target, prop, found, bool(strips))
    if strips:
        keyed = fcurves.key_frames(found)
        lo = min([s.frame_start for s in strips] + list(keyed[:1]))
        hi = max([s.frame_end for s in strips] + list(keyed[-1:]))
        frames = np.union1d(np.arange(math.floor(lo), math.ceil(hi) + 1, dtype=np.float64), keyed)
        values = evaluate_in_scene(target, prop, frames)
        notes.append("%s: NLA strips (%s) play on it: baked Blender's evaluated result (NLA included), "
                     "read at every frame %s..%s" % (target.name, ", ".join(s.name for s in strips),
                                                     num(frames[0]), num(frames[-1])))
    else:
        frames = fcurves.key_frames(found)
        if skip_key_type is not None:
            kept = [fcurves.read_keys(f)[0][fcurves.read_key_types(f) != skip_key_type] for f in found if f is not None]
            if any(len(k) for k in kept):
                frames = np.unique(np.concatenate(kept))
        values = evaluate_channels(target, prop, found, frames)
    bad = ~np.isfinite(values)
    if bad.any():
        k, i = np.argwhere(bad)[0]
        where = "at frame %s" % num(float(frames[k])) if found[i] is not None or strips else "(unkeyed value)"
        raise TargetError("%s: %s[%d] is %s %s" % (target.name, prop, i, values[k, i], where))
    return RotationKeys(target.name, mode, prop, frames, values,
                        key_count=sum(fcurves.key_count(f) for f in found if f is not None),
                        modifiers=tuple(tuple(m.type for m in f.modifiers) if f is not None else ()
                                        for f in found),
                        notes=notes, nla=bool(strips))


def refuse_drivers(target, prop, count):
    """A driver on a rotation channel overrides any keys: refuse, naming the channel."""
    anim = target.id_data.animation_data
    if anim is None:
        return
    path = target.data_path(prop)
    for i in range(count):
        if anim.drivers.find(path, index=i) is not None:
            raise TargetError("%s: %s[%d] is driven by a driver, which would override any baked keys "
                            "(remove the driver, or bake the driven result with Blender's own bake)"
                            % (target.name, prop, i))


def _refuse_jumps(target, prop, index, fcurve):
    """Two keys on one frame with different values (a jump) cannot be kept with one key per frame."""
    frames, values = fcurves.read_keys(fcurve)
    if len(frames) < 2 or (frames[1:] > frames[:-1]).all():
        return  # increasing frames (the usual, sorted case): no two keys share a frame
    order = np.argsort(frames, kind="stable")
    frames, values = frames[order], values[order]
    same = np.flatnonzero(frames[1:] == frames[:-1])
    for k in same:
        group = values[frames == frames[k]]
        if (group != group[0]).any():
            shown = [num(round(float(v), 6)) for v in group]
            raise TargetError("%s: %s[%d] has %d keys on frame %s (%s): a jump that one key per frame "
                            "cannot keep" % (target.name, prop, index, len(group), num(frames[k]),
                                             ", ".join(shown[:-1]) + " and " + shown[-1]))


def _channel_notes(target, prop, found, nla):
    notes = []
    held = [i for i, f in enumerate(found) if f is None]
    if held and not nla:
        current = getattr(target.owner, prop)
        notes.append("%s: %s not keyed: held at the current value%s (%s), as Blender plays %s"
                     % (target.name, "%s[%d]" % (prop, held[0]) + "".join(", [%d]" % i for i in held[1:]),
                        "s" if len(held) > 1 else "", ", ".join(num(round(current[i], 6)) for i in held),
                        "them" if len(held) > 1 else "it"))
    for i, fcurve in enumerate(found):
        if fcurve is not None and len(fcurve.modifiers):
            kinds = ", ".join(m.type for m in fcurve.modifiers)
            notes.append("%s: %s[%d] has F-curve modifier%s %s: Blender's evaluation at the key frames is "
                         "baked, the modifier's motion between keys is not" % (
                             target.name, prop, i, "s" if len(fcurve.modifiers) > 1 else "", kinds))
    constraints = [c.name for c in target.owner.constraints if not c.mute]
    if constraints:
        notes.append("%s: constraint%s (%s) still appl%s on top of the baked rotation channels"
                     % (target.name, "s" if len(constraints) > 1 else "", ", ".join(constraints),
                        "y" if len(constraints) > 1 else "ies"))
    return notes


def _other_keyed_hint(target, channels, prop):
    if channels is None:
        return ""
    for other in fcurves.ROTATION_PROPERTIES:
        path = target.data_path(other)
        if other != prop and any(f.data_path == path and fcurves.key_count(f) for f in channels.fcurves):
            return "; %s is keyed: set the rotation mode that uses it to bake it" % other
    return ""


def channels_to_quats(mode, values, name="", frames=None):
    """(N, 4) unit quaternions of channel values in `mode`, as Blender builds the rotation (native
    quatcurve.channels_to_quats). Zero quaternions or axes raise TargetError naming `name` and the
    frame."""
    values = np.asarray(values, dtype=np.float64)
    refuse_zero_rotations(mode, values, name, frames)
    return native.require().channels_to_quats(values, mode)


def refuse_zero_rotations(mode, values, name="", frames=None):
    """Raises TargetError naming `name` and the frame at the first zero quaternion or axis-angle axis
    among channel values (N, C) in `mode` (Euler angles always define a rotation)."""
    if mode in fcurves.EULER_ORDERS:
        return
    values = np.asarray(values, dtype=np.float64)
    norms = np.linalg.norm(values if mode == "QUATERNION" else values[:, 1:], axis=1)
    if (norms == 0).any():
        k = int(np.flatnonzero(norms == 0)[0])
        frame = " at frame %s" % num(float(frames[k])) if frames is not None else ""
        if mode == "QUATERNION":
            raise TargetError("%s: the quaternion is zero%s (no rotation defined)" % (name, frame))
        raise TargetError("%s: rotation_axis_angle[1..3] (the axis) is zero%s: no rotation axis defined"
                          % (name, frame))


def default_frame_range(targets):
    """(first, last) keyed frame over the targets' rotation keys in their current modes, whole frames
    (floor / ceil). Raises TargetError like read_rotation_keys for a target without rotation keys."""
    frames = [read_rotation_keys(t).frames for t in targets]
    return math.floor(min(f[0] for f in frames)), math.ceil(max(f[-1] for f in frames))
