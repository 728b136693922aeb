"""Baking: turn the rotation keys of objects and pose bones into dense LINEAR keys of a chosen method.

Plain functions, no operator state: the `quatcurve.bake` operator, the CLI and scripts call the same
code. Data flows one way: Blender's F-curves → key arrays (fcurves.py) → a native curve → sampled
quaternions → channel values in the output rotation mode → new F-curves (fcurves.py).

    targets = bake.gather_targets(bpy.context)          # or [bake.Target(obj), bake.Target(rig, "Bone")]
    result = bake.bake(targets, bake.BakeSettings(method="SQUAD", rotation_mode="QUATERNION"))
    print(result.summary())

Everything is read and computed before anything is written (`prepare` → `BakePlan.compute` →
`BakePlan.write`), so a BakeError or a cancelled bake leaves the file untouched.
"""

import math
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import fcurves, native

METHODS = ("EULER", "QUAT_COMPONENTS", "NLERP", "SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2")
OUTPUT_MODES = ("QUATERNION",) + fcurves.EULER_ORDERS + ("AXIS_ANGLE", "KEEP")
MAX_FRAMES = 10_000_000  # longest frame range a bake accepts (checked before allocating)


class BakeError(Exception):
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
    tolerance: float = 0.0            # degrees; > 0 asks for key reduction (through reduce_keys below)
    new_action: bool = True           # bake into a copy of each action; False: replace in place
    tension: float = 0.0              # TCB
    continuity: float = 0.0           # TCB
    bias: float = 0.0                 # TCB
    shortest_path: bool = True        # SLERP

    def curve_options(self):
        """Keyword options of quatcurve.Curve for this method (only the ones it accepts)."""
        if self.method == "TCB":
            return {"tension": self.tension, "continuity": self.continuity, "bias": self.bias}
        if self.method == "SLERP":
            return {"shortest_path": bool(self.shortest_path)}
        return {}


def check_settings(settings):
    """Raises BakeError for settings no bake can use (before any data is looked at)."""
    if settings.method not in METHODS:
        raise BakeError("method %r: unknown (expected one of %s)" % (settings.method, ", ".join(METHODS)))
    if settings.rotation_mode not in OUTPUT_MODES:
        raise BakeError("rotation mode %r: unknown (expected one of %s)"
                        % (settings.rotation_mode, ", ".join(OUTPUT_MODES)))
    if not (settings.step >= 1):  # also refuses NaN
        raise BakeError("step %s: must be at least 1 frame" % _num(settings.step))
    if not (settings.tolerance >= 0):
        raise BakeError("tolerance %s°: must be 0 or more" % _num(settings.tolerance))
    if settings.tolerance > 0 and reduce_keys is None:
        raise BakeError("tolerance %s°: key reduction is not available yet; use tolerance 0 "
                        "(a key every step frames)" % _num(settings.tolerance))


def _num(x):
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
    Raises BakeError when nothing is selected ("Nothing to <verb>: …")."""
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
        raise BakeError("Nothing to %s: no %s" % (verb, what))
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
    """Raises BakeError when the target's data may not be changed (library-linked or overridden)."""
    why = fcurves.is_protected(target.id_data)
    if why:
        raise BakeError("%s: the object is %s and cannot be changed" % (target.name, why))
    action = fcurves.active_action(target.id_data)
    why = fcurves.is_protected(action)
    if why and not new_action:
        raise BakeError("%s: action '%s' is %s and cannot be changed in place" % (target.name, action.name, why))


# ---- reading the source -------------------------------------------------------------------------------

@dataclass(eq=False)
class RotationKeys:
    """A target's rotation keys, as Blender evaluates them.

    mode: the rotation mode read (the target's); prop: 'rotation_euler' etc.; frames (K,): every frame
    where any channel of prop is keyed; values (K, 3|4): Blender's evaluation of each channel there
    (an unkeyed channel holds the property's value); fcurves: the channel F-curves (None if unkeyed)."""
    target: Target
    mode: str
    prop: str
    frames: np.ndarray
    values: np.ndarray
    fcurves: list
    notes: list = field(default_factory=list)   # what the bake report should tell the animator
    nla: bool = False                           # values are Blender's NLA-evaluated result

    @property
    def is_euler(self):
        return self.mode in fcurves.EULER_ORDERS

    def evaluate(self, frames):
        """Blender's evaluation of the channels at any `frames`: (N, 3|4) channel values (with NLA
        strips present: the whole animation evaluated, scene.frame_set)."""
        if self.nla:
            return evaluate_in_scene(self.target, self.prop, frames)
        return evaluate_channels(self.target, self.prop, self.fcurves, frames)

    def quats(self, frames=None):
        """Blender's orientation (w, x, y, z), at the key frames or at `frames`."""
        values = self.values if frames is None else self.evaluate(frames)
        return channels_to_quats(self.mode, values, self.target.name, self.frames if frames is None else frames)

    def curve(self, method, **options):
        """The native curve of `method` through these keys (Euler keys through Curve.from_euler, so
        turns beyond 180° between keys survive)."""
        qc = native.require()
        if self.is_euler:
            return qc.Curve.from_euler(self.frames, self.values, order=self.mode, method=method, **options)
        quats = self.quats()  # refuses zero quaternions / axes, naming the frame
        if self.mode == "QUATERNION":
            # The stored components as they are: QUAT_COMPONENTS lerps them before normalizing, as
            # Blender does, which differs from lerping normalized keys when they are not unit length.
            quats = self.values
        return qc.Curve(self.frames, quats, method=method, **options)


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


def read_rotation_keys(target, action=None):
    """RotationKeys of `target` in its current rotation mode, from `action` (default: its active
    action, and the NLA strips that play on it).

    Raises BakeError when the mode's channels have no keys, hold NaN/infinite values, have two keys
    with different values on one frame, or are driven by a driver. Notes (RotationKeys.notes) tell
    what a bake keeps: channels held at their current value, F-curve modifiers read at the keys,
    constraints that still apply, NLA strips whose evaluated result is read at every frame."""
    mode = target.owner.rotation_mode
    prop, count = fcurves.rotation_property(mode)
    path = target.data_path(prop)
    _refuse_drivers(target, prop, count)
    channels = fcurves.Channels.of(target.id_data, action)
    found = channels.find_all(path, count) if channels is not None else [None] * count
    found = [f if f is not None and fcurves.key_count(f) else None for f in found]
    strips = [] if action is not None else [
        strip for strip, strip_channels in fcurves.nla_strips(target.id_data)
        if strip_channels is not None and any(strip_channels.find(path, i) is not None for i in range(count))]
    if not any(found) and not strips:
        raise BakeError("%s: no rotation animation (rotation mode %s, no keys on %s)%s"
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
                                                     _num(frames[0]), _num(frames[-1])))
    else:
        frames = fcurves.key_frames(found)
        values = evaluate_channels(target, prop, found, frames)
    bad = ~np.isfinite(values)
    if bad.any():
        k, i = np.argwhere(bad)[0]
        where = "at frame %s" % _num(float(frames[k])) if found[i] is not None or strips else "(unkeyed value)"
        raise BakeError("%s: %s[%d] is %s %s" % (target.name, prop, i, values[k, i], where))
    return RotationKeys(target, mode, prop, frames, values, found, notes, nla=bool(strips))


def _refuse_drivers(target, prop, count):
    """A driver on a rotation channel overrides any keys: refuse, naming the channel."""
    anim = target.id_data.animation_data
    if anim is None:
        return
    path = target.data_path(prop)
    for i in range(count):
        if anim.drivers.find(path, index=i) is not None:
            raise BakeError("%s: %s[%d] is driven by a driver, which would override any baked keys "
                            "(remove the driver, or bake the driven result with Blender's own bake)"
                            % (target.name, prop, i))


def _refuse_jumps(target, prop, index, fcurve):
    """Two keys on one frame with different values (a jump) cannot be kept with one key per frame."""
    frames, values = fcurves.read_keys(fcurve)
    order = np.argsort(frames, kind="stable")
    frames, values = frames[order], values[order]
    same = np.flatnonzero(frames[1:] == frames[:-1])
    for k in same:
        group = values[frames == frames[k]]
        if (group != group[0]).any():
            shown = [_num(round(float(v), 6)) for v in group]
            raise BakeError("%s: %s[%d] has %d keys on frame %s (%s): a jump that one key per frame "
                            "cannot keep" % (target.name, prop, index, len(group), _num(frames[k]),
                                             ", ".join(shown[:-1]) + " and " + shown[-1]))


def _channel_notes(target, prop, found, nla):
    notes = []
    held = [i for i, f in enumerate(found) if f is None]
    if held and not nla:
        current = getattr(target.owner, prop)
        notes.append("%s: %s not keyed: held at the current value%s (%s), as Blender plays %s"
                     % (target.name, "%s[%d]" % (prop, held[0]) + "".join(", [%d]" % i for i in held[1:]),
                        "s" if len(held) > 1 else "", ", ".join(_num(round(current[i], 6)) for i in held),
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
    """(N, 4) unit quaternions of channel values in `mode` (as Blender builds the rotation: a
    quaternion is normalized, an axis-angle axis is normalized). Zero quaternions or axes raise
    BakeError naming `name` and the frame."""
    qc = native.require()
    values = np.asarray(values, dtype=np.float64)
    if mode in fcurves.EULER_ORDERS:
        return qc.euler_to_quat(values, mode)
    vec = values if mode == "QUATERNION" else values[:, 1:]
    norms = np.linalg.norm(vec, axis=1)
    if (norms == 0).any():
        k = int(np.flatnonzero(norms == 0)[0])
        frame = " at frame %s" % _num(float(frames[k])) if frames is not None else ""
        what = "quaternion" if mode == "QUATERNION" else "axis-angle axis"
        raise BakeError("%s: the %s is zero%s (no rotation defined)" % (name, what, frame))
    if mode == "QUATERNION":
        return qc.quat_normalize(values)
    return qc.axis_angle_to_quat(values[:, 1:], values[:, 0])


def default_frame_range(targets):
    """(first, last) keyed frame over the targets' rotation keys in their current modes, whole frames
    (floor / ceil). Raises BakeError like read_rotation_keys for a target without rotation keys."""
    frames = [read_rotation_keys(t).frames for t in targets]
    return math.floor(min(f[0] for f in frames)), math.ceil(max(f[-1] for f in frames))


def bake_frames(frame_start, frame_end, step):
    """The frames that get a key: frame_start, +step, … and frame_end itself (always keyed).
    Raises BakeError for an empty range, step < 1, or more than MAX_FRAMES frames — before
    allocating anything."""
    if not (step >= 1):
        raise BakeError("step %s: must be at least 1 frame" % _num(step))
    if not (math.isfinite(frame_start) and math.isfinite(frame_end)):
        raise BakeError("frame range %s..%s: not finite" % (_num(frame_start), _num(frame_end)))
    if frame_end < frame_start:
        raise BakeError("frame range %s..%s is empty" % (_num(frame_start), _num(frame_end)))
    if frame_end - frame_start > MAX_FRAMES:
        raise BakeError("frame range %s..%s is %s frames long: at most %s frames can be baked"
                        % (_num(frame_start), _num(frame_end), _num(frame_end - frame_start), f"{MAX_FRAMES:,}"))
    count = int(math.floor((frame_end - frame_start) / step + 1e-9)) + 1
    frames = frame_start + step * np.arange(count, dtype=np.float64)
    if frames[-1] < frame_end - 1e-6:
        frames = np.append(frames, float(frame_end))
    return frames


# ---- output values ----------------------------------------------------------------------------------------

def hemisphere_continuous(quats, reference=None):
    """quats with signs flipped so that neighbours have a non-negative dot product (each is still
    the same rotation); the first one takes the sign closest to `reference` when given."""
    quats = np.array(quats, dtype=np.float64)
    flips = np.empty(len(quats), dtype=bool)
    if len(quats) == 0:
        return quats
    flips[0] = reference is not None and float(np.dot(quats[0], reference)) < 0
    flips[1:] = np.einsum("ij,ij->i", quats[1:], quats[:-1]) < 0
    sign = np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)
    return quats * sign[:, None]


def continuous_axis_angle(quats, reference=None):
    """(N, 4) axis-angle channels (angle, x, y, z) of hemisphere-continuous quats, continuous from
    frame to frame: (axis, angle) and (−axis, −angle) are the same rotation, as are angles 2π apart
    (q vs −q), so the axis is kept on the side of its predecessor and the angle unwrapped. Where the
    rotation is (nearly) the identity the axis is undefined and the neighbour's axis is kept.
    `reference` (angle, x, y, z): the first frame's representation is chosen closest to it."""
    qc = native.require()
    axis, angle = qc.quat_to_axis_angle(quats)
    axis, angle = np.array(axis, dtype=np.float64), np.array(angle, dtype=np.float64)
    n = len(angle)
    if n == 0:
        return np.empty((0, 4))
    # Undefined axes (|sin(angle/2)| tiny) take the nearest defined one before them (or after).
    defined = np.abs(np.sin(0.5 * angle)) > 1e-7
    if defined.any():
        index = np.where(defined, np.arange(n), -1)
        index = np.maximum.accumulate(index)
        index[index < 0] = np.flatnonzero(defined)[0]
        axis = axis[index]
    sign = np.ones(n)
    sign[1:] = np.where(np.einsum("ij,ij->i", axis[1:], axis[:-1]) < 0, -1.0, 1.0)
    if reference is not None and np.dot(axis[0], reference[1:4]) < 0:
        sign[0] = -1.0
    sign = np.cumprod(sign)
    axis, angle = axis * sign[:, None], angle * sign
    start = reference[0] if reference is not None else angle[0]
    angle = np.unwrap(np.concatenate([[start], angle]), period=2 * math.pi)[1:]
    return np.column_stack([angle, axis])


def output_values(quats, mode, reference=None):
    """(N, 3|4) channel values of `mode` for sampled quats, continuous along the samples.

    reference, when the target's source keys are already in `mode`: for QUATERNION and AXIS_ANGLE
    the source's channel values at the first frame (the first sample takes the representation
    closest to it); for an Euler order an (N, 3) path of the source's angles at every sample, which
    each sample's Euler solution is chosen closest to (so the baked angles keep the keyed turn counts).

    Euler continuity: euler_filter runs forward and backward from the sample farthest from gimbal
    lock. Starting at a locked sample (the fixed-angle example starts at (0°, 90°, 0°)) would leave
    the choice between the two solutions to rounding, as both are equally near; starting where they
    are far apart makes it unambiguous, and the locked sample then takes the member of its family
    closest to its neighbour."""
    qc = native.require()
    if mode == "QUATERNION":
        return hemisphere_continuous(quats, reference)
    if mode == "AXIS_ANGLE":
        return continuous_axis_angle(hemisphere_continuous(quats), reference)
    if reference is None:
        angles = np.array(qc.quat_to_euler(quats, mode), dtype=np.float64)
    else:
        angles = np.array(qc.quat_to_euler(quats, mode, compat=np.asarray(reference, dtype=np.float64)))
    if len(angles) < 2:
        return angles
    anchor = int(np.argmax(qc.gimbal_distances(angles, mode)))
    angles[anchor:] = qc.euler_filter(angles[anchor:], mode)
    angles[:anchor + 1] = qc.euler_filter(angles[anchor::-1], mode)[::-1]
    return angles


# Key reduction hook (issue 6). While None, check_settings refuses tolerance > 0. Set it to a function
#     reduce_keys(frames (N,), values (N, C), mode, tolerance_radians) -> reduced
# where `reduced` has .interpolation ('LINEAR' or 'BEZIER'), .keys — per channel (frames, values,
# handle_left, handle_right), handles (K, 2) for BEZIER or None — .key_count and .max_error (radians);
# it raises ValueError when it cannot reduce. The bake then writes those keys instead of the dense ones
# and reports keys and max error. (reduce.reduce_values has exactly this shape.)
reduce_keys = None


# ---- plan, compute, write -------------------------------------------------------------------------------

@dataclass(eq=False)
class TargetBake:
    """One target's bake, computed but not yet written."""
    target: Target
    source: RotationKeys
    output_mode: str
    frames: np.ndarray = None
    values: np.ndarray = None    # (N, 3|4) output channel values
    own_action: bool = False     # in place was asked for, but others play the action: copy it
    reduced: object = None       # reduce_keys' result when tolerance > 0
    notes: list = field(default_factory=list)


@dataclass
class TargetResult:
    name: str
    source_mode: str
    output_mode: str
    source_keys: int
    keys_written: int
    action: str
    notes: list = field(default_factory=list)


@dataclass
class BakeResult:
    method: str
    frame_start: float
    frame_end: float
    targets: list = field(default_factory=list)
    keys_written: int = 0
    seconds: float = 0.0

    def summary(self):
        return "%d target%s, %s keys, %.2f s" % (len(self.targets), "" if len(self.targets) == 1 else "s",
                                                f"{self.keys_written:,}", self.seconds)

    def lines(self):
        """One line per target, each followed by its notes (held channels, modifiers, NLA, …)."""
        out = []
        for t in self.targets:
            out.append("%s: %s %s → %s, %d source keys → %s keys in '%s'"
                       % (t.name, self.method, t.source_mode, t.output_mode, t.source_keys,
                          f"{t.keys_written:,}", t.action))
            out.extend(t.notes)
        return out

    def notes(self):
        return [note for t in self.targets for note in t.notes]


class BakePlan:
    """A validated bake: sources read, frames chosen. `compute_steps()` (or `compute()`) samples the
    curves target by target without touching Blender data; `write()` then writes everything. Drop the
    plan to cancel: nothing has changed until write()."""

    def __init__(self, targets, settings, sources, frames, seconds):
        self.settings = settings
        self.frames = frames
        self.items = [TargetBake(t, s, s.mode if settings.rotation_mode == "KEEP" else settings.rotation_mode)
                      for t, s in zip(targets, sources)]
        self.seconds = seconds   # working time so far (a modal bake's idle time is not counted)
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
        for _ in self.compute_steps():
            pass
        return self

    def _compute(self, item):
        settings, source = self.settings, item.source
        try:
            curve = source.curve(settings.method, **settings.curve_options())
            quats = np.asarray(curve.sample(self.frames), dtype=np.float64)
        except ValueError as error:
            raise BakeError("%s: %s" % (item.target.name, error)) from error
        reference = None
        if source.mode == item.output_mode and source.is_euler:
            # The keyed angles, linear between keys: a cheap guide to the branch, not output math.
            reference = np.column_stack([np.interp(self.frames, source.frames, source.values[:, i])
                                         for i in range(3)])
        elif source.mode == item.output_mode:
            reference = source.evaluate(self.frames[:1])[0]
        item.frames = self.frames
        item.values = output_values(quats, item.output_mode, reference)
        if not np.isfinite(item.values).all():
            raise BakeError("%s: the %s curve gave non-finite values" % (item.target.name, settings.method))
        if settings.tolerance > 0:
            try:
                item.reduced = reduce_keys(self.frames, item.values, item.output_mode,
                                           math.radians(settings.tolerance))
            except ValueError as error:
                raise BakeError("%s: key reduction: %s" % (item.target.name, error)) from error
            item.notes.append("%s: reduced to %s keys within %s° (max error %.4f°)" % (
                item.target.name, f"{item.reduced.key_count:,}", _num(settings.tolerance),
                math.degrees(item.reduced.max_error)))

    def write(self):
        """Writes every computed target (see module doc); returns the BakeResult."""
        if self.computed < len(self.items):
            self.compute()
        begin = time.perf_counter()
        settings = self.settings
        result = BakeResult(settings.method, float(self.frames[0]), float(self.frames[-1]))
        copies = {}        # original action → its baked copy (shared by every target using it)
        destination = {}   # ID → the action its targets are written into
        for item in self.items:
            id_data = item.target.id_data
            if id_data.name_full not in destination:
                original = fcurves.active_action(id_data)
                if original is None:  # only NLA strips: the baked result becomes the active action
                    action = fcurves.new_action(id_data, "%s_%s" % (id_data.name, settings.method.lower()))
                elif settings.new_action or item.own_action:
                    if original not in copies:
                        copies[original] = fcurves.copy_action(
                            original, "%s_%s" % (original.name, settings.method.lower()))
                    action = copies[original]
                else:
                    action = original
                destination[id_data.name_full] = action
            action = destination[id_data.name_full]
            channels = fcurves.Channels.of(id_data, action, create=True)
            written = _write_target(channels, item)
            result.keys_written += written
            result.targets.append(TargetResult(item.target.name, item.source.mode, item.output_mode,
                                               len(item.source.frames), written, action.name,
                                               item.source.notes + item.notes))
        for item in self.items:
            id_data = item.target.id_data
            action = destination[id_data.name_full]
            if fcurves.active_action(id_data) != action:
                fcurves.assign_action(id_data, action)
            item.target.owner.rotation_mode = item.output_mode
        for original in copies:
            original.use_fake_user = True
        for id_data in {item.target.id_data.name_full: item.target.id_data for item in self.items}.values():
            id_data.update_tag(refresh={"TIME"})  # re-evaluate the animation on the next update
        self.seconds += time.perf_counter() - begin
        result.seconds = self.seconds
        return result


def _write_target(channels, item):
    """Replaces every rotation F-curve of the target (all three rotation properties) by LINEAR keys of
    the output mode, in the group the old rotation curves were in (none if they had none). Returns the
    key count."""
    target = item.target
    paths = [target.data_path(p) for p in fcurves.ROTATION_PROPERTIES]
    group = next((g for g in (channels.group_of(p) for p in paths) if g), None)
    channels.remove(paths, count=4)  # rotation properties have at most 4 channels
    prop, count = fcurves.rotation_property(item.output_mode)
    path = target.data_path(prop)
    if item.reduced is not None:
        for i, (frames, values, left, right) in enumerate(item.reduced.keys):
            channels.write(path, i, frames, values, group=group, interpolation=item.reduced.interpolation,
                           handle_left=left, handle_right=right)
        return item.reduced.key_count
    for i in range(count):
        channels.write(path, i, item.frames, item.values[:, i], group=group)
    return item.values.size


def prepare(targets, settings):
    """Checks settings and targets and reads every source; returns a BakePlan (nothing written).
    Raises BakeError naming what is wrong."""
    begin = time.perf_counter()
    check_settings(settings)
    if not targets:
        raise BakeError("Nothing to bake: no targets")
    for target in targets:
        check_editable(target, settings.new_action)
    sources = [read_rotation_keys(t) for t in targets]
    if settings.rotation_mode != "KEEP":
        for target in targets:
            _refuse_drivers(target, *fcurves.rotation_property(settings.rotation_mode))
    start, end = settings.frame_start, settings.frame_end
    if start is None:
        start = math.floor(min(s.frames[0] for s in sources))
    if end is None:
        end = math.ceil(max(s.frames[-1] for s in sources))
    frames = bake_frames(start, end, settings.step)
    plan = BakePlan(targets, settings, sources, frames, time.perf_counter() - begin)
    if not settings.new_action:
        _keep_shared_actions(plan)
    return plan


def _keep_shared_actions(plan):
    """In place was asked for, but an action a target plays is also played by objects that are not
    being baked (through the same slot, ≥ 4.4): changing it would silently change them, so those
    targets get their own new action instead, and the report says so."""
    ids = {item.target.id_data.name_full for item in plan.items}
    for item in plan.items:
        id_data = item.target.id_data
        action = fcurves.active_action(id_data)
        if action is None:
            continue
        others = [o.name for o in fcurves.action_users(action, fcurves.slot_identifier(id_data))
                  if o.name_full not in ids]
        if others:
            item.own_action = True
            item.notes.append("%s: action '%s' is also used by %s: baked into a new action instead of in "
                              "place, so %s keep%s playing it" % (
                                  item.target.name, action.name, ", ".join(sorted(others)),
                                  "they" if len(others) > 1 else "it", "" if len(others) > 1 else "s"))


def bake(targets, settings):
    """Bakes `targets` with `settings` synchronously; returns the BakeResult. On BakeError nothing
    has been changed."""
    return prepare(targets, settings).compute().write()
