"""Writing results: rotation keys into a new action (a copy of the target's, or a new one when only
NLA strips play on it) or in place, in bulk, with the target's rotation mode set to the keys' mode.
The writing layer of the add-on: bake and reduce end here.

Nothing is written until `write_rotations` runs, and it runs only after every target has been read
and computed, so an error earlier leaves the file untouched; the operators' UNDO flag makes the
whole write one undo step. F-curves are touched only through fcurves.py.
"""

from dataclasses import dataclass


from . import fcurves


@dataclass(eq=False)
class RotationWrite:
    """One target's new rotation keys.

    keys: per channel of `mode`, (frames, values, handle_left, handle_right) — handles (K, 2)
    arrays of (frame, value) for BEZIER keys, None otherwise — or fcurves.PackedKeys (LINEAR or
    CONSTANT keys packed beforehand: the bake packs them on its workers, Curve.sample_keys). replace: the rotation properties whose
    F-curves are removed first (all three when the mode changes). own_action: in place was asked
    for, but the action is shared with objects not being written: write into a copy instead.
    cycles: a loop's keys (one period): per channel (mode_before, mode_after) of the Cycles modifier
    put on its new F-curve (None: none on that channel), or one pair for every channel.
    key_interpolations: per channel, each key's interpolation where they differ (the reduction's keys
    copied from the original around its sign flips), None: `interpolation` for every key."""
    target: object
    mode: str
    keys: list
    interpolation: str = "LINEAR"
    replace: tuple = fcurves.ROTATION_PROPERTIES
    own_action: bool = False
    cycles: tuple = None
    key_interpolations: list = None

    @property
    def key_count(self):
        return sum(len(k) if isinstance(k, fcurves.PackedKeys) else len(k[0]) for k in self.keys)


def shared_with(target, ids):
    """Names of the objects outside `ids` (ID full names) that play the target's action (through the
    same slot, ≥ 4.4): writing it in place would silently change them."""
    action = fcurves.active_action(target.id_data)
    if action is None:
        return []
    return sorted(o.name for o in fcurves.action_users(action, fcurves.slot_identifier(target.id_data))
                  if o.name_full not in ids)


def write_rotations(items, new_action, suffix):
    """Writes every RotationWrite; returns the action each was written into (in order).

    new_action: each target's action is copied as '<action>_<suffix>' (one copy per action, shared by
    every target playing it), the copy assigned and the original kept with a fake user; otherwise the
    keys replace the rotation curves in place (unless item.own_action). A target with only NLA
    strips gets a new action '<object>_<suffix>'. Keys go into the group the replaced curves were in.

    items: a list, or with new_action an iterator that computes the writes one by one (the bake
    overlaps its computing with the writing this way). Until every item is written only actions made
    here are touched: when the iterator or a write raises, they are removed again (which unassigns
    the new ones) and the file is as it was."""
    if not new_action and not isinstance(items, (list, tuple)):
        raise TypeError("write_rotations: in place, the writes must all be computed first (a list)")
    copies = {}        # original action → its copy
    destination = {}   # ID → the action its targets are written into, and the ID's Channels there
    made = []          # actions made here
    written, done = [], []
    try:
        for item in items:
            id_data = item.target.id_data
            if id_data.name_full not in destination:
                original = fcurves.active_action(id_data)
                if original is None:  # only NLA strips: the result becomes the active action
                    action = fcurves.new_action(id_data, "%s_%s" % (id_data.name, suffix))
                    made.append(action)
                elif new_action or item.own_action:
                    if original not in copies:
                        copies[original] = fcurves.copy_action(original, "%s_%s" % (original.name, suffix))
                        made.append(copies[original])
                    action = copies[original]
                else:
                    action = original
                destination[id_data.name_full] = action, fcurves.Channels.of(id_data, action, create=True)
            action, channels = destination[id_data.name_full]
            _write_keys(channels, item)
            written.append(action)
            done.append(item)
    except BaseException:
        for action in made:
            fcurves.remove_action(action)
        raise
    for item in done:
        id_data = item.target.id_data
        action = destination[id_data.name_full][0]
        if fcurves.active_action(id_data) != action:
            fcurves.assign_action(id_data, action)
        if item.target.owner.rotation_mode != item.mode:
            item.target.owner.rotation_mode = item.mode
    for original in copies:
        original.use_fake_user = True
    for id_data in {item.target.id_data.name_full: item.target.id_data for item in done}.values():
        id_data.update_tag(refresh={"TIME"})  # re-evaluate the animation on the next update
    return written


def _write_keys(channels, item):
    """Replaces the F-curves of item.replace by the item's keys, in the group the old ones were in
    (none if they had none)."""
    target = item.target
    paths = [target.data_path(p) for p in item.replace]
    group = next((g for g in (channels.group_of(p) for p in paths) if g), None)
    channels.remove(paths, count=4)  # rotation properties have at most 4 channels
    path = target.data_path(fcurves.rotation_property(item.mode)[0])
    for index, keys in enumerate(item.keys):
        if isinstance(keys, fcurves.PackedKeys):
            fcurve = channels.write_packed(path, index, keys, group=group, interpolation=item.interpolation)
        else:
            frames, values, left, right = keys
            interpolation = item.interpolation if item.key_interpolations is None else item.key_interpolations[index]
            fcurve = channels.write(path, index, frames, values, group=group, interpolation=interpolation,
                                    handle_left=left, handle_right=right)
        modes = item.cycles[index] if item.cycles and isinstance(item.cycles[0], tuple) else item.cycles
        if modes:
            fcurves.add_cycles(fcurve, *modes)
