"""Armatures (and objects) as a quatcurve.Skeleton: the bones' rest data and every bone's local
channels as Blender evaluates them, for the distance bound of the key reduction (reduce.py,
error='DISTANCE'). Reading only: nothing here changes the file.

    read = skeleton.read_armature(rig, ["Hips", "Spine"])   # the bones to reduce; every bone is posed
    result = read.skeleton().reduce(read.frames, read.rotations, read.locations, read.scales, ...)

The samples are every whole frame and every key of any bone's rotation (in its current mode),
location and scale channels over the armature's keyed range. Unkeyed channels hold their current
value. Locations and scales are read, never reduced.

Refused with a TargetError naming the armature, bone and channel or constraint: what changes the pose
beyond the bones' own channels or what the native pose does not model — NLA strips playing on the
armature, drivers on pose bones, unmuted constraints on a bone, F-curve modifiers on a bone's
location, rotation or scale, inherit scale other than Full or None, Local Location off, Relative
Parenting, an action (slot) that also animates another armature. (B-Bone segments bend the
deformation only, not pose_bone.matrix: not refused.)
"""

import re
from dataclasses import dataclass, field

import numpy as np

from . import fcurves, native, targets
from .targets import Target, TargetError

INHERIT_SCALE = ("FULL", "NONE")  # the modes quatcurve.Skeleton models


@dataclass(eq=False)
class ReadSkeleton:
    """An armature's (or one object's) bones as plain arrays, in parent-first order, and every
    bone's channels at `frames`: rotations [(mode, (N, C) values)], locations and scales (B, N, 3).
    reduced (B,) booleans: the bones whose rotation keys are reduced (the selected ones); the
    others are posed as they are. keys_before (B,): rotation keys on each bone's channels."""
    object: object
    targets: list               # Target per bone
    parents: np.ndarray
    rest: np.ndarray
    lengths: np.ndarray
    inherit_rotation: np.ndarray
    connected: np.ndarray
    inherit_scale: list
    frames: np.ndarray
    rotations: list
    locations: np.ndarray
    scales: np.ndarray
    reduced: np.ndarray
    props: list = field(default_factory=list)     # rotation property per bone ('rotation_euler', …)
    keys_before: np.ndarray = None

    @property
    def names(self):
        return [t.bone if t.bone is not None else t.object.name for t in self.targets]

    def skeleton(self):
        """The quatcurve.Skeleton of these bones. Raises TargetError naming the object and bone where
        the native skeleton refuses one (a rest matrix that is not a rigid transform, say)."""
        try:
            return native.require().Skeleton(self.parents, self.rest, self.lengths, self.inherit_rotation,
                                              self.connected, self.inherit_scale)
        except ValueError as error:
            names = self.names
            text = re.sub(r"\b(parents|rest|lengths|inherit_rotation|connected|inherit_scale)\[(\d+)\]",
                          lambda m: "bone '%s' (%s)" % (names[int(m.group(2))], m.group(1))
                          if int(m.group(2)) < len(names) else m.group(0), str(error))
            raise TargetError("%s: %s" % (self.object.name, text)) from None


def _parent_first(bones):
    """The armature's bones with every parent before its children (depth first from the roots)."""
    order = []
    stack = [b for b in reversed(bones) if b.parent is None]
    while stack:
        bone = stack.pop()
        order.append(bone)
        stack.extend(reversed(bone.children))
    return order


def _channel_fcurves(channels, path, count):
    found = channels.find_all(path, count) if channels is not None else [None] * count
    return [f if f is not None and fcurves.key_count(f) else None for f in found]


def _refuse_modifiers(name, prop, found):
    for index, fcurve in enumerate(found):
        if fcurve is not None and len(fcurve.modifiers):
            raise TargetError("%s: %s[%d] has F-curve modifiers (%s); the distance bound holds for keys alone "
                              "(apply or remove the modifiers first)" % (
                                  name, prop, index, ", ".join(m.type for m in fcurve.modifiers)))


def _refuse_animation_system(obj, what):
    strips = fcurves.nla_strips(obj)
    if strips:
        raise TargetError("%s: NLA strips (%s) play on it; the distance bound is for its action alone (bake the "
                          "NLA or mute the strips first)" % (obj.name, ", ".join(s.name for s, _ in strips)))
    anim = obj.animation_data
    for driver in (anim.drivers if anim is not None else ()):
        if what is None or driver.data_path.startswith(what):
            raise TargetError("%s: %s[%d] is driven by a driver, which changes the pose beyond the keys "
                              "(remove the driver first)" % (obj.name, driver.data_path, driver.array_index))


def _refuse_shared_action(obj):
    """An armature whose action (slot) also animates another armature: its new keys would move the
    other's bones, whose skeleton the bound did not measure."""
    import bpy
    others = [o.name for o in bpy.data.objects if o != obj and o.type == "ARMATURE" and fcurves.shares_channels(o, obj)]
    if others:
        raise TargetError("%s: its action '%s' also animates %s, whose bones the distance bound of this armature "
                          "does not measure (give each armature its own action: Make Single User)"
                          % (obj.name, fcurves.active_action(obj).name, ", ".join(sorted(others))))


def _sampled(owner_target, found_by_prop, frames):
    return {prop: targets.evaluate_channels(owner_target, prop, found, frames)
            for prop, found in found_by_prop.items()}


def read_armature(obj, reduced_names, span=None):
    """ReadSkeleton of armature object `obj`, every bone posed, the bones named in `reduced_names`
    reduced. span (first, last): sampled over these frames instead of the keyed range (every whole
    frame and every key within them; the glTF export's range). Raises TargetError as the module
    says, and as targets.read_rotation_keys for a bone to reduce (no rotation keys, drivers, jumps,
    NaN)."""
    return _sampled_skeleton(obj, *_armature_channels(obj, reduced_names), span=span)


def check_armature(obj, replaced_names):
    """Raises TargetError where read_armature would refuse `obj` once the bones named in
    `replaced_names` have new rotation keys (the bake's, before it writes them): their rotation
    channels are not looked at; everything else is, without sampling anything."""
    _armature_channels(obj, (), replaced=set(replaced_names))


def check_object(obj):
    """Raises TargetError where read_object would refuse `obj` once it has new rotation keys (the
    bake's): what plays on it besides its keys, and modifiers on its scale."""
    _refuse_animation_system(obj, None)
    channels = fcurves.Channels.of(obj)
    _refuse_modifiers(obj.name, "scale", _channel_fcurves(channels, Target(obj).data_path("scale"), 3))


def _armature_channels(obj, reduced_names, replaced=frozenset()):
    """The refusals of read_armature, and what it samples: (bones in parent-first order, per bone
    (target, rotation mode, rotation property, {property: F-curves}), the keyed frames per property,
    bone index by name, the names reduced). Bones in `replaced` have their rotation channels left
    out of the checks."""
    _refuse_animation_system(obj, "pose.bones[")
    _refuse_shared_action(obj)
    bones = _parent_first(list(obj.data.bones))
    index = {b.name: i for i, b in enumerate(bones)}
    channels = fcurves.Channels.of(obj)
    wanted = set(reduced_names)
    keyed, per_bone = [], []
    for bone in bones:
        pb = obj.pose.bones[bone.name]
        name = "%s/%s" % (obj.name, bone.name)
        if bone.inherit_scale not in INHERIT_SCALE:
            raise TargetError("%s: inherit scale %s is not modelled by the distance bound (Full or None; or "
                              "reduce with error='ANGLE')" % (name, bone.inherit_scale))
        if not bone.use_local_location:
            raise TargetError("%s: Local Location is off, which the distance bound does not model (turn it on, or "
                              "reduce with error='ANGLE')" % name)
        if getattr(bone, "use_relative_parent", False):
            raise TargetError("%s: Relative Parenting is on, which the distance bound does not model" % name)
        active = [c.name for c in pb.constraints if not c.mute and c.influence > 0]
        if active:
            raise TargetError("%s: constraint%s %s change%s the pose beyond the bone's channels; the distance "
                              "bound is on the channels' pose (mute or apply %s, or reduce with error='ANGLE')"
                              % (name, "s" if len(active) > 1 else "", ", ".join("'%s'" % c for c in active),
                                 "" if len(active) > 1 else "s", "them" if len(active) > 1 else "it"))
        target = Target(obj, bone.name)
        prop, count = fcurves.rotation_property(pb.rotation_mode)
        found = {prop: _channel_fcurves(channels, target.data_path(prop), count),
                 "location": _channel_fcurves(channels, target.data_path("location"), 3),
                 "scale": _channel_fcurves(channels, target.data_path("scale"), 3)}
        for p, f in found.items():
            if not (p == prop and bone.name in replaced):
                _refuse_modifiers(name, p, f)
        if bone.name in wanted:
            targets.read_rotation_keys(target)  # refuses what today's reduction refuses
        keyed += [fcurves.key_frames([f for f in fs if f is not None]) for fs in found.values() if any(fs)]
        per_bone.append((target, pb.rotation_mode, prop, found))
    missing = sorted((wanted | set(replaced)) - set(index))
    if missing:
        raise TargetError("%s: no bone %s" % (obj.name, missing[0]))
    return bones, per_bone, keyed, index, wanted


def _sample_frames(obj, keyed, span):
    """Every whole frame and every key of `keyed` over the keyed range, or over `span` (first, last)."""
    if span is None:
        if not keyed:
            raise TargetError("%s: no keys on any bone" % obj.name)
        return native.require().whole_frame_samples(np.unique(np.concatenate(keyed)))
    first, last = span
    frames = np.unique(np.concatenate(keyed + [np.array([first, last], dtype=np.float64)]))
    frames = native.require().whole_frame_samples(frames)
    return frames[(frames >= first) & (frames <= last)]


def _sampled_skeleton(obj, bones, per_bone, keyed, index, wanted, span=None):
    frames = _sample_frames(obj, keyed, span)
    rotations, locations, scales, props, keys_before = [], [], [], [], []
    for target, mode, prop, found in per_bone:
        values = _sampled(target, found, frames)
        for p, v in values.items():
            if not np.isfinite(v).all():
                raise TargetError("%s: %s evaluates to non-finite values" % (target.name, p))
        targets.refuse_zero_rotations(mode, values[prop], target.name, frames)
        rotations.append((mode, values[prop]))
        locations.append(values["location"])
        scales.append(values["scale"])
        props.append(prop)
        keys_before.append(sum(fcurves.key_count(f) for f in found[prop] if f is not None))
    read = ReadSkeleton(
        obj, [t for t, *_ in per_bone],
        np.array([index[b.parent.name] if b.parent is not None else -1 for b in bones]),
        np.array([np.array(b.matrix_local) for b in bones]).reshape(len(bones), 4, 4),
        np.array([b.length for b in bones], dtype=np.float64),
        np.array([b.use_inherit_rotation for b in bones]), np.array([b.use_connect for b in bones]),
        [b.inherit_scale for b in bones], frames, rotations, np.array(locations), np.array(scales),
        np.array([b.name in wanted for b in bones]), props, np.array(keys_before))
    read.skeleton()  # refused here, naming the bone, rather than where the reduction first needs it
    return read


def read_object(obj, span=None, keys_required=True):
    """ReadSkeleton of an object alone: one bone of length 0 at the object's origin (its three shell
    points), posed by its rotation and scale (times its delta scale); its location moves every point
    alike and is left out. span: as read_armature. keys_required: refuse an object without rotation
    keys (as the reduction does)."""
    _refuse_animation_system(obj, None)
    target = Target(obj)
    if keys_required:
        targets.read_rotation_keys(target)  # refuses what today's reduction refuses
    channels = fcurves.Channels.of(obj)
    prop, count = fcurves.rotation_property(obj.rotation_mode)
    found = {prop: _channel_fcurves(channels, target.data_path(prop), count),
             "scale": _channel_fcurves(channels, target.data_path("scale"), 3)}
    for p, f in found.items():
        _refuse_modifiers(obj.name, p, f)
    keyed = [fcurves.key_frames([f for f in fs if f is not None]) for fs in found.values() if any(fs)]
    frames = _sample_frames(obj, keyed, span)
    values = _sampled(target, found, frames)
    targets.refuse_zero_rotations(obj.rotation_mode, values[prop], obj.name, frames)
    scale = values["scale"] * np.array(obj.delta_scale)
    return ReadSkeleton(obj, [target], np.array([-1]), np.eye(4)[None], np.zeros(1), np.array([True]),
                        np.array([False]), ["FULL"], frames, [(obj.rotation_mode, values[prop])],
                        np.zeros((1, len(frames), 3)), scale[None], np.array([True]), [prop],
                        np.array([sum(fcurves.key_count(f) for f in found[prop] if f is not None)]))
