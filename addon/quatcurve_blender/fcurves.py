"""The one F-curve adapter: every read and write of actions and F-curves in the add-on goes through here.

Blender stores animation in two ways, and this module hides the difference:
- Blender < 4.4 (Debian's 3.4.1): legacy actions — `action.fcurves`, `action.groups`.
- Blender ≥ 4.4 (4.5 LTS, 5.x): slotted actions — `action.slots`, `action.layers[].strips[]`, one
  channelbag of F-curves and groups per slot, and `AnimData.action_slot` naming the slot an ID uses.
  Only this API is used there, never the legacy `action.fcurves` (5.0 removed it), so the 4.5 tests
  exercise the code path 5.x depends on. The branch is on `bpy.app.version`, not `hasattr`, because
  4.3 has experimental slotted types beside the legacy ones.

A `Channels` is the set of F-curves that animate one ID in one action (the legacy action itself, or
the channelbag of the ID's slot). Keys move in bulk, as numpy arrays through `foreach_get` /
`foreach_set` — never one Python call per key. Frames and values come back as float64; Blender stores
float32.
"""

import contextlib
import hashlib

import bpy
import numpy as np

from . import native

# Slotted actions are the only action API from 4.4 on (4.3's were experimental).
SLOTTED = bpy.app.version >= (4, 4, 0)

# Rotation properties of objects and pose bones, by rotation mode, with their channel counts.
EULER_ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
ROTATION_PROPERTIES = ("rotation_quaternion", "rotation_euler", "rotation_axis_angle")


def rotation_property(mode):
    """(property name, channel count) holding the rotation in `mode` ('QUATERNION', an Euler order,
    'AXIS_ANGLE'). Axis-angle channels are (angle, x, y, z); quaternion channels (w, x, y, z)."""
    if mode == "QUATERNION":
        return "rotation_quaternion", 4
    if mode == "AXIS_ANGLE":
        return "rotation_axis_angle", 4
    if mode in EULER_ORDERS:
        return "rotation_euler", 3
    raise ValueError("unknown rotation mode %r" % (mode,))


_ENUM_VALUES = {}  # (struct, prop, identifier) → value: RNA's enum items never change in a session


def _enum_value(struct, prop, identifier):
    key = (struct, prop, identifier)
    value = _ENUM_VALUES.get(key)
    if value is None:
        value = _ENUM_VALUES[key] = struct.bl_rna.properties[prop].enum_items[identifier].value
    return value


# ---- actions ------------------------------------------------------------------------------------

def active_action(id_data):
    """The action assigned to `id_data` (None without animation data or action)."""
    anim = id_data.animation_data
    return anim.action if anim is not None else None


def shares_channels(a, b):
    """Whether ID blocks a and b play the same F-curves: the same active action and (4.4+) the same
    slot of it."""
    action = active_action(a)
    return (action is not None and active_action(b) == action
            and (not SLOTTED or _slot_identifier(a) == _slot_identifier(b)))


def _slot_identifier(id_data):
    anim = id_data.animation_data
    slot = anim.action_slot if anim is not None else None
    return slot.identifier if slot is not None else None


def copy_action(action, name):
    """A full copy of `action` (every slot, layer, channel, group and key) named `name` (Blender adds
    .001 on a clash). The copy has no users until assigned."""
    copy = action.copy()
    copy.name = name
    return copy


def assign_action(id_data, action):
    """Makes `action` the active action of `id_data`, keeping the slot identifier the ID used (≥ 4.4:
    a copy of an action carries the same slots), so the ID keeps playing the same channels."""
    identifier = _slot_identifier(id_data) if SLOTTED else None
    anim = id_data.animation_data or id_data.animation_data_create()
    anim.action = action
    if SLOTTED and identifier is not None:
        slot = next((s for s in action.slots if s.identifier == identifier), None)
        if slot is not None and anim.action_slot != slot:
            anim.action_slot = slot


def new_action(id_data, name):
    """A new, empty action assigned to `id_data` (≥ 4.4: with a slot for it, assigned too), ready for
    `Channels.of(id_data, create=True)`."""
    action = bpy.data.actions.new(name)
    anim = id_data.animation_data or id_data.animation_data_create()
    anim.action = action
    if SLOTTED and anim.action_slot is None:
        anim.action_slot = action.slots.new(id_type=id_data.id_type, name=id_data.name)
    return action


def remove_action(action):
    """Deletes `action` from the file (it must not be needed any more)."""
    bpy.data.actions.remove(action)


def is_protected(id_data):
    """Why `id_data` cannot be edited: 'library-linked', 'override-protected', or '' when it can."""
    if id_data is None:
        return ""
    if getattr(id_data, "library", None) is not None:
        return "library-linked"
    if getattr(id_data, "override_library", None) is not None:
        return "override-protected"
    return ""


# ---- channels -------------------------------------------------------------------------------------

class Channels:
    """The F-curves animating one ID in one action.

    3.4: the legacy action itself. ≥ 4.4: the channelbag of the ID's slot; `create=True` makes the
    layer, keyframe strip and channelbag when missing (needs a slot: the ID's or a new one)."""

    def __init__(self, action, slot=None, bag=None):
        self.action = action
        self.slot = slot
        self._bag = bag if SLOTTED else action

    @classmethod
    def of(cls, id_data, action=None, create=False):
        """Channels of `id_data` in `action` (default: its active action); None when it has none.
        In a copy of the ID's action, the ID's slot is found by its identifier."""
        action = action or active_action(id_data)
        if action is None:
            return None
        if not SLOTTED:
            return cls(action)
        identifier = _slot_identifier(id_data)
        slot = next((s for s in action.slots if s.identifier == identifier), None) if identifier else None
        if slot is None:
            return None
        bag = _channelbag(action, slot, create)
        return cls(action, slot, bag) if bag is not None else None

    @classmethod
    def of_slot(cls, action, slot=None):
        """Channels of `slot` in `action` (≥ 4.4; ignored before): None when the slot has none."""
        if not SLOTTED:
            return cls(action)
        bag = _channelbag(action, slot, False) if slot is not None else None
        return cls(action, slot, bag) if bag is not None else None

    @property
    def fcurves(self):
        return self._bag.fcurves if self._bag is not None else ()

    def find(self, data_path, index=0):
        return self._bag.fcurves.find(data_path, index=index) if self._bag is not None else None

    def find_all(self, data_path, count):
        """[F-curve or None] for indices 0..count-1 of `data_path`."""
        return [self.find(data_path, i) for i in range(count)]

    def group_of(self, data_path, count=4):
        """Name of the group of the first F-curve on `data_path` (indices below `count`), or None."""
        for index in range(count):
            fcurve = self.find(data_path, index)
            if fcurve is not None and fcurve.group is not None:
                return fcurve.group.name
        return None

    def remove(self, data_paths, count=None):
        """Removes the F-curves on `data_paths` — indices below `count` (found directly), or every
        index when count is None (a scan of all curves); returns how many."""
        if count is None:
            doomed = [f for f in self.fcurves if f.data_path in data_paths]
        else:
            doomed = [f for f in (self.find(p, i) for p in data_paths for i in range(count)) if f is not None]
        for fcurve in doomed:
            self._bag.fcurves.remove(fcurve)
        return len(doomed)

    def new_fcurve(self, data_path, index, group=None):
        """A new, empty F-curve (in group `group`, created when missing)."""
        if not SLOTTED:
            if group:
                return self.action.fcurves.new(data_path, index=index, action_group=group)
            return self.action.fcurves.new(data_path, index=index)
        if self._bag is None:
            raise RuntimeError("channels without a channelbag cannot hold F-curves")
        fcurve = self._bag.fcurves.new(data_path, index=index)
        if group:
            fcurve.group = self._bag.groups.get(group) or self._bag.groups.new(group)
        return fcurve

    def write(self, data_path, index, frames, values, group=None, **keys):
        """A new F-curve on (data_path, index) holding the given keys; see `write_keys`."""
        fcurve = self.new_fcurve(data_path, index, group)
        write_keys(fcurve, frames, values, **keys)
        return fcurve

    def write_packed(self, data_path, index, packed, group=None, interpolation="LINEAR"):
        """A new F-curve on (data_path, index) holding PackedKeys; see `write_packed`."""
        fcurve = self.new_fcurve(data_path, index, group)
        write_packed(fcurve, packed, interpolation)
        return fcurve


def nla_strips(id_data):
    """The NLA strips that play on `id_data` (unmuted strips of unmuted tracks, while the NLA is
    used), each with the Channels of its action for the strip's slot (≥ 4.4) — or None when the
    strip's action has no channels for it."""
    anim = id_data.animation_data
    if anim is None or not anim.use_nla:
        return []
    found = []
    for track in anim.nla_tracks:
        if track.mute:
            continue
        for strip in track.strips:
            if strip.mute or strip.action is None:
                continue
            if not SLOTTED:
                found.append((strip, Channels(strip.action)))
                continue
            slot = strip.action_slot
            bag = _channelbag(strip.action, slot, False) if slot is not None else None
            found.append((strip, Channels(strip.action, slot, bag) if bag is not None else None))
    return found


def action_users(action, slot_identifier=None):
    """Objects playing `action` (as their active action or in an NLA strip) — on ≥ 4.4 only through
    the slot `slot_identifier` when given (other slots hold other channels)."""
    users = []
    for obj in bpy.data.objects:
        anim = obj.animation_data
        if anim is None:
            continue
        uses = anim.action == action and (not SLOTTED or slot_identifier is None or
                                          _slot_identifier(obj) == slot_identifier)
        for track in anim.nla_tracks:
            for strip in track.strips:
                if strip.action == action and (not SLOTTED or slot_identifier is None or
                                               (strip.action_slot is not None and
                                                strip.action_slot.identifier == slot_identifier)):
                    uses = True
        if uses:
            users.append(obj)
    return users


def action_slots(action):
    """The slots of `action` (≥ 4.4); [None] before (a legacy action is one set of channels)."""
    return list(action.slots) if SLOTTED else [None]


def played_slot(id_data, action):
    """The slot through which `id_data` plays `action` — as its active action or in an NLA strip
    (≥ 4.4) — or None (also before 4.4, where actions have no slots)."""
    anim = id_data.animation_data
    if not SLOTTED or anim is None:
        return None
    if anim.action == action and anim.action_slot is not None:
        return anim.action_slot
    for track in anim.nla_tracks:
        for strip in track.strips:
            if strip.action == action and strip.action_slot is not None:
                return strip.action_slot
    return None


def slot_identifier(id_data):
    """Identifier of the action slot `id_data` plays (≥ 4.4), else None."""
    return _slot_identifier(id_data) if SLOTTED else None


def _channelbag(action, slot, create):
    for layer in action.layers:
        for strip in layer.strips:
            if strip.type == "KEYFRAME":
                bag = strip.channelbag(slot)
                if bag is not None:
                    return bag
    if not create:
        return None
    # bpy_extras.anim_utils.action_ensure_channelbag_for_slot does this from 5.0 on (4.5 has only a
    # private helper): first layer, first keyframe strip, then the slot's channelbag.
    layer = action.layers[0] if len(action.layers) else action.layers.new("Layer")
    strip = layer.strips[0] if len(layer.strips) else layer.strips.new(type="KEYFRAME")
    return strip.channelbag(slot, ensure=True)


def all_fcurves(action):
    """Every F-curve of `action`, over all slots (≥ 4.4) — for digests and reports."""
    if not SLOTTED:
        return list(action.fcurves)
    found = []
    for layer in action.layers:
        for strip in layer.strips:
            if strip.type == "KEYFRAME":
                for bag in strip.channelbags:
                    found.extend(bag.fcurves)
    return found


@contextlib.contextmanager
def scratch_channels(name="quatcurve scratch", id_type="OBJECT"):
    """Channels in a new, unassigned action that is removed on exit — for letting Blender evaluate
    curves the add-on builds (compare), without touching the user's data."""
    action = bpy.data.actions.new(name)
    try:
        if SLOTTED:
            slot = action.slots.new(id_type=id_type, name="Scratch")
            yield Channels(action, slot, _channelbag(action, slot, create=True))
        else:
            yield Channels(action)
    finally:
        remove_action(action)


# ---- keys -----------------------------------------------------------------------------------------

def key_count(fcurve):
    return len(fcurve.keyframe_points)


# (F-curve pointer, key count) → (frames, values), inside read_cache() only.
_read_cache = None


@contextlib.contextmanager
def read_cache():
    """Within the block read_keys reads each F-curve from Blender once (reading a task's targets
    asks for the same keys up to four times: frames, jumps, evaluation); the arrays it returns are
    then read-only. Nothing may change keys inside the block. Main thread only, like all bpy use."""
    global _read_cache
    outer = _read_cache
    if outer is None:
        _read_cache = {}
    try:
        yield
    finally:
        if outer is None:
            _read_cache = None


def read_keys(fcurve):
    """(frames, values), float64 arrays of the F-curve's keys in stored order (sorted after update)."""
    n = len(fcurve.keyframe_points)
    cache = _read_cache
    if cache is not None:
        key = (fcurve.as_pointer(), n)
        if key in cache:
            return cache[key]
    co = np.empty(2 * n, dtype=np.float32)
    fcurve.keyframe_points.foreach_get("co", co)
    co = co.astype(np.float64)
    keys = co[0::2], co[1::2]
    if cache is not None:
        co.flags.writeable = False
        cache[key] = keys
    return keys


def read_handles(fcurve):
    """(left, right) handle positions, float64 arrays (N, 2) of (frame, value)."""
    n = len(fcurve.keyframe_points)
    left, right = np.empty(2 * n, np.float32), np.empty(2 * n, np.float32)
    fcurve.keyframe_points.foreach_get("handle_left", left)
    fcurve.keyframe_points.foreach_get("handle_right", right)
    return left.astype(np.float64).reshape(n, 2), right.astype(np.float64).reshape(n, 2)


def segment_interpolations(fcurve):
    """The interpolations Blender evaluates between the F-curve's keys (each key's, the last one's
    excepted: a key's interpolation shapes the segment after it), as a set of identifiers ('LINEAR',
    'BEZIER', 'CONSTANT', 'BOUNCE', …). Read in bulk."""
    n = len(fcurve.keyframe_points)
    if n < 2:
        return set()
    raw = _get_enum(fcurve.keyframe_points, "interpolation", n)[:-1]
    items = {item.value: item.identifier
             for item in bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items}
    return {items.get(int(v), str(int(v))) for v in np.unique(raw)}


def key_frames(fcurves):
    """Sorted union of the key frames of the given F-curves (None entries are skipped)."""
    parts = [read_keys(f)[0] for f in fcurves if f is not None]
    if not parts:
        return np.empty(0)
    first = np.array(parts[0])  # a copy: read_keys may hand out read-only (cached) arrays
    if ((len(first) < 2 or (first[1:] > first[:-1]).all())
            and all(len(p) == len(first) and np.array_equal(p, first) for p in parts[1:])):
        return first  # the usual case, channels keyed together in order: np.unique's own answer
    return np.unique(np.concatenate(parts))


def evaluate(fcurve, frames):
    """Blender's own evaluation of `fcurve` at `frames` (interpolation, extrapolation, modifiers).

    Fast path: at a frame where the curve has a key and no modifier, Blender's evaluation is exactly
    the key's value (its keyframe search returns the stored value on an exact frame match, for every
    interpolation), so that value is read in bulk; all other frames go through `fcurve.evaluate`."""
    frames = np.asarray(frames, dtype=np.float64)
    out = np.empty(frames.shape, dtype=np.float64)
    todo = np.ones(frames.shape, dtype=bool)
    if len(fcurve.modifiers) == 0 and len(fcurve.keyframe_points):
        key_f, key_v = read_keys(fcurve)
        increasing = len(key_f) < 2 or bool((key_f[1:] > key_f[:-1]).all())
        if increasing and frames.shape == key_f.shape and np.array_equal(frames, key_f):
            return key_v.copy()  # exactly the key frames (a dense curve read at its own keys)
        if not increasing:
            order = np.argsort(key_f, kind="stable")
            key_f, key_v = key_f[order], key_v[order]
        where = np.clip(np.searchsorted(key_f, frames), 0, len(key_f) - 1)
        hit = key_f[where] == frames
        # Duplicate key frames: Blender's search may land on either; leave those to evaluate().
        if not increasing:
            dup = np.zeros(len(key_f), dtype=bool)
            same = key_f[1:] == key_f[:-1]
            dup[1:] |= same
            dup[:-1] |= same
            hit &= ~dup[where]
        out[hit] = key_v[where[hit]]
        todo = ~hit
    # One RNA call per frame left, made by map over plain floats: no Python frame or numpy scalar
    # per call (0.4 µs a frame against 1 µs for an indexed loop).
    out[todo] = list(map(fcurve.evaluate, frames[todo].tolist()))
    return out


# Raw type of Keyframe's enums (interpolation, handle types, key type) in bulk I/O: foreach_set and
# foreach_get take a fast (memcpy-like) path only when the buffer's type matches the DNA field — char
# in 3.x, uint8_t in 4.x/5.x — and go key by key through RNA otherwise (14-25x slower; the values are
# the same either way).
KEY_ENUM_DTYPE = np.int8 if bpy.app.version < (4, 0, 0) else np.uint8
# Reading them, and writing handle types: Blender 3.4's raw path reads bytes from elsewhere for these
# (action digests changed between two reads), so there they go through int32 buffers — RNA's own path,
# which reads correctly and ignores handle-type writes (set key by key instead, see _set_free_handles).
KEY_ENUM_READ_DTYPE = np.int32 if bpy.app.version < (4, 0, 0) else np.uint8
_NO_ENUM = -1 if KEY_ENUM_READ_DTYPE == np.int32 else 255  # no enum value: a buffer left untouched


def evaluate_scratch_keys(data_path, key_frames, key_values, frames, interpolation="BEZIER", cycle=None):
    """(N, C) Blender's evaluation at `frames` of C channels keyed (key_frames, key_values[:, c]) with
    `interpolation` — 'BEZIER' with Blender's default AUTO_CLAMPED handles, computed by Blender
    (fcurve.update()), as keyframe_insert makes them; or 'LINEAR' — built in a scratch action that is
    removed before returning. data_path: e.g. 'rotation_euler' (only the name of the curves).
    cycle: None (open), 'REPEAT' or 'REPEAT_OFFSET': every channel gets a plain Cycles modifier in
    that mode before its handles are computed, so Blender's cycle-aware auto handles apply (the seam
    is a key like the others) and frames outside the keys repeat the period."""
    key_values = np.asarray(key_values, dtype=np.float64)
    key_values = key_values.reshape(len(key_values), -1)
    frames = np.asarray(frames, dtype=np.float64)
    out = np.empty((len(frames), key_values.shape[1]))
    with scratch_channels() as scratch:
        for c in range(key_values.shape[1]):
            fcurve = scratch.write(data_path, c, key_frames, key_values[:, c], interpolation=interpolation)
            if cycle is not None:
                add_cycles(fcurve, cycle, cycle)
            fcurve.update()  # Blender computes the automatic handles (cycle-aware with the modifier)
            out[:, c] = evaluate(fcurve, frames)
    return out


class PackedKeys:
    """Keys packed for `foreach_set`, as Blender stores them: co, (2N,) float32 (frame, value) pairs;
    increasing: whether the frames increase (then no sort is needed). Made by `pack_keys` from plain
    arrays, touching no Blender data, so worker threads can pack while the main thread writes."""

    __slots__ = ("co", "increasing")

    def __init__(self, frames, values):
        frames = np.asarray(frames, dtype=np.float64)
        values = np.asarray(values, dtype=np.float64)
        n = len(frames)
        if values.shape != (n,):
            raise ValueError("values: expected shape (%d,), got %s" % (n, values.shape))
        co = np.empty((n, 2), dtype=np.float32)
        co[:, 0], co[:, 1] = frames, values
        self.co = co.ravel()
        self.increasing = bool(n < 2 or (frames[1:] > frames[:-1]).all())

    @classmethod
    def from_pairs(cls, pairs, increasing):
        """PackedKeys of (N, 2) float32 (frame, value) rows packed already (Curve.sample_keys), whose
        frames increase or not as `increasing` says."""
        packed = cls.__new__(cls)
        packed.co = np.ascontiguousarray(pairs, dtype=np.float32).reshape(-1)
        packed.increasing = bool(increasing)
        return packed

    def __len__(self):
        return len(self.co) // 2


def write_packed(fcurve, packed, interpolation="LINEAR"):
    """Replaces the keys of `fcurve` by PackedKeys, in bulk: the plainest write Blender has
    (keyframe_points.add, foreach_set of co and interpolation), sorted by update() only when the
    frames do not increase. For LINEAR and CONSTANT keys (see write_keys on handles)."""
    points = fcurve.keyframe_points
    if len(points):
        points.clear()
    n = len(packed)
    points.add(n)
    points.foreach_set("co", packed.co)
    kind = _enum_value(bpy.types.Keyframe, "interpolation", interpolation)
    points.foreach_set("interpolation", np.full(n, kind, dtype=KEY_ENUM_DTYPE))
    if not packed.increasing:
        fcurve.update()
    return fcurve


def add_cycles(fcurve, mode_before="REPEAT", mode_after="REPEAT"):
    """Makes `fcurve` a loop of its keys: a Cycles modifier, repeating without end (cycles.py reads
    this form back as a loop)."""
    modifier = fcurve.modifiers.new("CYCLES")
    modifier.mode_before, modifier.mode_after = mode_before, mode_after
    modifier.cycles_before = modifier.cycles_after = 0
    return modifier


def write_keys(fcurve, frames, values, interpolation="LINEAR", handle_left=None, handle_right=None,
               with_handles=False):
    """Replaces the keys of `fcurve` by (frames[i], values[i]), in bulk.

    interpolation: 'LINEAR' or 'CONSTANT' — handles are left unset, as Blender's own bake does
    (bpy_extras.anim_utils): they do not take part in these interpolations, are not drawn for them,
    and any edit in Blender recomputes them (they keep the AUTO_CLAMPED type) — or 'BEZIER' with
    `handle_left` and `handle_right` given as (N, 2) arrays of (frame, value), written as FREE
    handles so Blender keeps them (the key-reduction path); or one identifier per key (the
    reduction's keys copied from the original keep its interpolation). `with_handles=True` places
    LINEAR keys' handles on the straight segments (a third of the way to each neighbour) at some cost.

    Increasing frames skip fcurve.update() (a sort and an automatic-handle pass, the largest cost of
    a dense write); otherwise update() sorts the keys."""
    if (handle_left is None) != (handle_right is None):
        raise ValueError("handle_left and handle_right go together")
    packed = PackedKeys(frames, values)
    n = len(packed)
    points = fcurve.keyframe_points
    old = len(points)
    # Where handle types can only be set key by key (Blender 3.4), rewriting a keyed F-curve (a refit)
    # keeps its key slots — FREE already after a fit — and sets only the handle types that are not.
    reuse = handle_left is not None and old > 0 and _BULK_ENUM.get("handle_left_type") is False
    if reuse:
        for _ in range(old - n):
            points.remove(points[len(points) - 1], fast=True)
        if n > old:
            points.add(n - old)
    else:
        if old:
            points.clear()
        points.add(n)
    points.foreach_set("co", packed.co)
    if isinstance(interpolation, str):
        kinds = np.full(n, _enum_value(bpy.types.Keyframe, "interpolation", interpolation), dtype=KEY_ENUM_DTYPE)
    else:
        kinds = np.array([_enum_value(bpy.types.Keyframe, "interpolation", str(name)) for name in interpolation],
                         dtype=KEY_ENUM_DTYPE)
    points.foreach_set("interpolation", kinds)
    if reuse:
        for point in points:
            if point.handle_left_type != "FREE":
                point.handle_left_type = "FREE"
            if point.handle_right_type != "FREE":
                point.handle_right_type = "FREE"
        # foreach_set tags nothing, and with the slots kept no add/clear did: the action's
        # evaluated copy must be made again, or Blender plays the keys it had
        fcurve.id_data.update_tag()
    elif handle_left is not None:
        _set_free_handles(points, n)
    elif with_handles:
        handle_left, handle_right = native.require().segment_handles(frames, values)
    if handle_left is not None:
        points.foreach_set("handle_left", np.asarray(handle_left, dtype=np.float32).reshape(n, 2).ravel())
        points.foreach_set("handle_right", np.asarray(handle_right, dtype=np.float32).reshape(n, 2).ravel())
    if not packed.increasing:
        fcurve.update()
    return fcurve


_ENUM_FILLS = {}  # (value, n, dtype) → a read-only array of n × value: the enum buffers writes share


def _enum_fill(value, n, dtype):
    key = (value, n, dtype)
    buf = _ENUM_FILLS.get(key)
    if buf is None:
        if len(_ENUM_FILLS) >= 256:
            _ENUM_FILLS.clear()
        buf = _ENUM_FILLS[key] = np.full(n, value, dtype=dtype)
        buf.flags.writeable = False
    return buf


def read_co_types(curves):
    """(co (C, 2N) float32, types (C, N) as Blender stores them, KEY_ENUM_READ_DTYPE) of C F-curves
    holding N keys each, in two bulk reads per F-curve into shared arrays (a key type left unread
    keeps the no-value fill, which read_keys_together checks) — or None when one is missing or they
    hold different key counts or none."""
    if not curves or any(curve is None for curve in curves):
        return None
    n = len(curves[0].keyframe_points)
    if not n or any(len(curve.keyframe_points) != n for curve in curves):
        return None
    co = np.empty((len(curves), 2 * n), dtype=np.float32)
    types = np.full((len(curves), n), _NO_ENUM, dtype=KEY_ENUM_READ_DTYPE)
    for c, curve in enumerate(curves):
        points = curve.keyframe_points
        points.foreach_get("co", co[c])
        points.foreach_get("type", types[c])
    return co, types


def read_keys_together(curves, read=None):
    """(co (C, 2N) float32, types (C, N) int64, selected (C, N) bool) of C F-curves holding N keys each
    (the rotation channels of a target keyed together), in three bulk reads per F-curve into shared
    arrays — or None when one is missing, they hold different key counts or none, or Blender cannot
    read key types in bulk here (then read them one by one: read_keys, read_key_types,
    read_key_selection). read: read_co_types(curves) when the caller has it (nothing changed keys
    since): only the selection is read then."""
    if not curves or any(curve is None for curve in curves):
        return None
    n = len(curves[0].keyframe_points)
    if not n or any(len(curve.keyframe_points) != n for curve in curves):
        return None
    if bpy.app.version < (4, 0, 0) and curves[0].id_data.library is not None:
        return None  # 3.4 reads enums of a linked action's keys wrong in bulk (_get_enum)
    if not _BULK_ENUM.get("get type", True):
        return None
    if read is None or read[1].shape != (len(curves), n):
        read = read_co_types(curves)
    co, types = read
    selected = np.empty((len(curves), n), dtype=bool)
    for c, curve in enumerate(curves):
        curve.keyframe_points.foreach_get("select_control_point", selected[c])
    if (types == _NO_ENUM).any():
        return None
    return co, types.astype(np.int64), selected


_BEZIER_FREE_FILLS = {}  # key count → (BEZIER interpolation, FREE handle type) buffers of rewrite_handles


def rewrite_handles(fcurve, co, handle_left, handle_right):
    """Rewrites the keys an F-curve holds, keeping their slots (and with them their types and
    selection): co, (2N,) float32 (frame, value) pairs, or None to leave the frames and values as they
    are; handle_left and handle_right, (2N,) float32, written as FREE handles of BEZIER keys (as
    write_keys writes them), so no interpolation or handle type an animator set stays. The frames
    must increase, and the caller tags the action (foreach_set tags nothing): see fit.write_plan."""
    points = fcurve.keyframe_points
    n = len(points)
    if co is not None:
        points.foreach_set("co", co)
    fills = _BEZIER_FREE_FILLS.get(n)
    if fills is None:
        if len(_BEZIER_FREE_FILLS) >= 256:
            _BEZIER_FREE_FILLS.clear()
        fills = _BEZIER_FREE_FILLS[n] = (
            _enum_fill(_enum_value(bpy.types.Keyframe, "interpolation", "BEZIER"), n, KEY_ENUM_DTYPE),
            _enum_fill(_enum_value(bpy.types.Keyframe, "handle_left_type", "FREE"), n, KEY_ENUM_READ_DTYPE))
    points.foreach_set("interpolation", fills[0])
    bulk = _BULK_ENUM.get("handle_left_type")
    if bulk:  # 4.x, 5.x: known to take handle types in bulk
        points.foreach_set("handle_left_type", fills[1])
        points.foreach_set("handle_right_type", fills[1])
    elif bulk is False:  # 3.4: key by key, only those not FREE already
        for point in points:
            if point.handle_left_type != "FREE":
                point.handle_left_type = "FREE"
            if point.handle_right_type != "FREE":
                point.handle_right_type = "FREE"
    else:
        _set_free_handles(points, n)
    points.foreach_set("handle_left", handle_left)
    points.foreach_set("handle_right", handle_right)
    return fcurve


# Whether bulk foreach_set / foreach_get work on a Keyframe enum property in this Blender, learnt
# from the first use (prop → bool): Blender 3.4 ignores both on handle types, 4.x and 5.x take them.
# Knowing it spares every later call the bulk attempt and the read-back check.
_BULK_ENUM = {}


def _set_free_handles(points, n):
    """Handle types FREE on every key. In bulk where Blender supports it (4.x, 5.x); Blender 3.4
    ignores foreach_set on handle types, so there it falls back to one assignment per key (only the
    key-reduction path writes handles, and it writes few keys)."""
    if not n:
        return
    free = _enum_value(bpy.types.Keyframe, "handle_left_type", "FREE")
    if _BULK_ENUM.get("handle_left_type", True):
        buf = _enum_fill(free, n, KEY_ENUM_READ_DTYPE)
        points.foreach_set("handle_left_type", buf)
        points.foreach_set("handle_right_type", buf)
        if "handle_left_type" in _BULK_ENUM:
            return
        works = bool((_get_enum(points, "handle_right_type", n) == free).all()
                     and (_get_enum(points, "handle_left_type", n) == free).all())
        _BULK_ENUM["handle_left_type"] = works
        if works:
            return
    for point in points:
        point.handle_left_type = point.handle_right_type = "FREE"


def _get_enum(points, prop, n):
    """Enum values of every key (as int32). Blender 3.4's foreach_get leaves handle-type buffers
    untouched, so a buffer still holding its no-value fill is read key by key (and from then on
    directly); on a library-linked action it fills even `interpolation` with bytes from elsewhere
    (seen in the fault table's digests), so there every key is read through RNA."""
    linked = bpy.app.version < (4, 0, 0) and points.id_data.library is not None
    if not linked and _BULK_ENUM.get("get " + prop, True):
        raw = np.full(n, _NO_ENUM, dtype=KEY_ENUM_READ_DTYPE)
        points.foreach_get(prop, raw)
        if not n or not (raw == _NO_ENUM).any():
            if n:
                _BULK_ENUM["get " + prop] = True
            return raw.astype(np.int32)
        _BULK_ENUM["get " + prop] = False
    items = bpy.types.Keyframe.bl_rna.properties[prop].enum_items
    return np.array([items[getattr(point, prop)].value for point in points], dtype=np.int32).reshape(n)


def read_key_types(fcurve):
    """Raw keyframe types of every key (int64): KEYFRAME 0, EXTREME 1, BREAKDOWN 2, JITTER 3,
    MOVING_HOLD 4, GENERATED 5 (4.2+)."""
    return _get_enum(fcurve.keyframe_points, "type", len(fcurve.keyframe_points)).astype(np.int64)


# Key types are the raw values 0 .. _KEY_TYPE_COUNT - 1 (0 when they are not: then every write is read back).
_KEY_TYPE_VALUES = sorted(item.value for item in bpy.types.Keyframe.bl_rna.properties["type"].enum_items)
_KEY_TYPE_COUNT = len(_KEY_TYPE_VALUES) if _KEY_TYPE_VALUES == list(range(len(_KEY_TYPE_VALUES))) else 0


def write_key_types(fcurve, types):
    """Sets every key's type from raw values, in bulk where Blender takes it, key by key otherwise
    (checked by reading back, as for handle types; once the bulk write of types known to Blender was
    read back right, such writes are not read back again)."""
    points = fcurve.keyframe_points
    n = len(points)
    types = np.asarray(types, dtype=np.int64)
    points.foreach_set("type", types.astype(KEY_ENUM_DTYPE))
    if not n:
        return
    known = bool(types.min() >= 0 and types.max() < _KEY_TYPE_COUNT)
    if known and _BULK_ENUM.get("set type"):
        return
    read_back = np.array_equal(_get_enum(points, "type", n), types)
    if known and read_back:
        _BULK_ENUM["set type"] = True
    if not read_back:
        items = {item.value: item.identifier for item in bpy.types.Keyframe.bl_rna.properties["type"].enum_items}
        for point, t in zip(points, types):
            point.type = items[int(t)]


def read_key_selection(fcurve):
    """Whether each key (its control point) is selected, bool array."""
    n = len(fcurve.keyframe_points)
    buf = np.zeros(n, dtype=bool)
    fcurve.keyframe_points.foreach_get("select_control_point", buf)
    return buf


def write_key_selection(fcurve, selected):
    """Selects the keys where `selected` is True (control points and both handles), deselects the rest."""
    selected = np.asarray(selected, dtype=bool)
    for prop in ("select_control_point", "select_left_handle", "select_right_handle"):
        fcurve.keyframe_points.foreach_set(prop, selected)


# ---- digests ----------------------------------------------------------------------------------------

def fcurve_digest(fcurve, h=None):
    """sha256 over an F-curve's path, index, group, keys (frames, values, handles, interpolation),
    modifiers and flags that change its evaluation."""
    h = h or hashlib.sha256()
    h.update(("%s[%d] group=%s mute=%s extrapolation=%s mods=%s\n" % (
        fcurve.data_path, fcurve.array_index, fcurve.group.name if fcurve.group else "", fcurve.mute,
        fcurve.extrapolation, ",".join(m.type for m in fcurve.modifiers))).encode())
    n = len(fcurve.keyframe_points)
    points = fcurve.keyframe_points
    for prop in ("co", "handle_left", "handle_right"):
        buf = np.empty(2 * n, dtype=np.float32)
        points.foreach_get(prop, buf)
        h.update(buf.tobytes())
    for prop in ("interpolation", "handle_left_type", "handle_right_type"):
        h.update(_get_enum(points, prop, n).tobytes())
    return h


def action_digest(action):
    """sha256 hex digest of every F-curve of `action` (all slots), in a stable order; equal digests
    mean key-for-key equal actions."""
    h = hashlib.sha256()
    for fcurve in sorted(all_fcurves(action), key=lambda f: (f.data_path, f.array_index)):
        fcurve_digest(fcurve, h)
    if SLOTTED:
        h.update(("slots=%s" % sorted(s.identifier for s in action.slots)).encode())
    return h.hexdigest()
