"""Loops: which rotation targets Blender plays as a cycle, and their period.

Blender plays an F-curve as a cycle when its FIRST modifier is a Cycles modifier that is not muted,
has no restricted frame range and no influence, repeats without end (before and after counts 0) and
repeats the same way on both sides: Repeat (a perfect cycle) or Repeat with Offset (each period
starts where the last ended) — `BKE_fcurve_get_cycle_type`. Mirror is not a cycle. One period runs
from the curve's first key to its last; cycle-aware keying keeps both end keys equal.

A rotation target is a loop when every keyed rotation channel is such a cycle over the same first
and last key frames. Anything else on a rotation channel — another modifier, a Cycles modifier that
is not the first, Mirror, a muted or range-restricted one, channels of one target with different
periods or some cyclic and some not — is refused by `target_loop`, naming the target, the channel
and the modifier (CycleError, a TargetError), so no task reads such a curve as a loop or as open.

Repeat with Offset is part of the loop on Euler and axis-angle channels (a wheel keyed 0° → 360°
with offset keeps turning: the offset per period is the last key minus the first); on quaternion
channels an offset would scale and skew the rotation, and is refused.

An action's Cyclic Animation (manual frame range with `use_cyclic`, Blender 3.1+) states the period
where it is set: the loop's first and last key frames must then be the range's start and end.
"""

from dataclasses import dataclass

from . import fcurves
from .targets import TargetError, num

CYCLE_MODES = ("REPEAT", "REPEAT_OFFSET")


class CycleError(TargetError):
    """A rotation channel's modifiers that no task can read as a loop or as open keys."""


@dataclass(frozen=True)
class Loop:
    """A target's loop: one period from `start` to `end` (frames, the first and last key), and
    whether its channels repeat with offset (Euler and axis-angle only)."""
    start: float
    end: float
    offset: bool = False

    @property
    def period(self):
        return self.end - self.start


def _describe(modifier):
    if modifier.type != "CYCLES":
        return modifier.type
    return "CYCLES %s/%s" % (modifier.mode_before, modifier.mode_after)


def channel_cycle(fcurve):
    """'REPEAT' or 'REPEAT_OFFSET' when Blender plays `fcurve` as a cycle, None when it has no
    modifier at all; otherwise the reason it is neither (a string for CycleError)."""
    modifiers = list(fcurve.modifiers)
    if not modifiers:
        return None, None
    first = modifiers[0]
    if first.type != "CYCLES":
        return None, "has F-curve modifiers (%s)" % ", ".join(_describe(m) for m in modifiers)
    if len(modifiers) > 1:
        return None, "has F-curve modifiers after its Cycles modifier (%s)" % ", ".join(
            _describe(m) for m in modifiers[1:])
    if first.mute:
        return None, "has a muted Cycles modifier"
    if getattr(first, "is_valid", True) is False:
        return None, "has a Cycles modifier Blender marks invalid"
    if first.use_restricted_range:
        return None, "has a Cycles modifier with a restricted frame range"
    if first.use_influence:
        return None, "has a Cycles modifier with an influence"
    if first.cycles_before or first.cycles_after:
        return None, "has a Cycles modifier with a finite count (before %d, after %d): a loop repeats without end" % (
            first.cycles_before, first.cycles_after)
    before, after = first.mode_before, first.mode_after
    if before == after == "REPEAT":
        return "REPEAT", None
    if before in CYCLE_MODES and after in CYCLE_MODES:
        return "REPEAT_OFFSET", None
    return None, "has a Cycles modifier in modes %s/%s (a loop repeats: Repeat or Repeat with Offset on both sides)" % (
        before, after)


def target_loop(name, prop, curves, mode, action=None):
    """The Loop of a target's rotation channels `curves` (F-curves or None, channel order of `prop`),
    or None when none has a modifier. `name` names the target in errors, `mode` is its rotation
    mode; `action`, when given, may state the period by its Cyclic Animation range. Raises
    CycleError naming the target, the channel and the modifier for anything else."""
    keyed = [(c, curve) for c, curve in enumerate(curves) if curve is not None and len(curve.keyframe_points)]
    kinds = {}
    for c, curve in keyed:
        kind, why = channel_cycle(curve)
        if why is not None:
            raise CycleError("%s: %s[%d] %s: only a plain Cycles modifier (first, not muted, no restricted "
                             "range or influence, Repeat or Repeat with Offset) is read, as a loop" % (name, prop, c, why))
        kinds[c] = kind
    if all(kind is None for kind in kinds.values()):
        return None
    open_channels = [c for c, kind in kinds.items() if kind is None]
    if open_channels:
        cyclic = next(c for c, kind in kinds.items() if kind is not None)
        raise CycleError("%s: %s[%d] has a Cycles modifier and %s[%d] none: a loop needs one on every rotation channel"
                         % (name, prop, cyclic, prop, open_channels[0]))
    offset = any(kind == "REPEAT_OFFSET" for kind in kinds.values())
    if offset and mode == "QUATERNION":
        c = next(c for c, kind in kinds.items() if kind == "REPEAT_OFFSET")
        raise CycleError("%s: %s[%d] has a Cycles modifier in Repeat with Offset: a quaternion channel's offset would "
                         "scale and skew the rotation; use Repeat (a loop ends on its first pose)" % (name, prop, c))
    ends = {}
    for c, curve in keyed:
        points = curve.keyframe_points
        ends[c] = (float(points[0].co[0]), float(points[-1].co[0]))
    first_c, (start, end) = next(iter(ends.items()))
    for c, (s, e) in ends.items():
        if (s, e) != (start, end):
            raise CycleError("%s: %s[%d] loops over frames %s–%s and %s[%d] over %s–%s: a target's rotation channels "
                             "need one period" % (name, prop, first_c, num(start), num(end), prop, c, num(s), num(e)))
    if not end > start:
        raise CycleError("%s: %s[%d] has a Cycles modifier and one key (frame %s): a loop needs a period"
                         % (name, prop, first_c, num(start)))
    if action is not None and getattr(action, "use_frame_range", False) and getattr(action, "use_cyclic", False):
        a0, a1 = float(action.frame_start), float(action.frame_end)
        if (a0, a1) != (start, end):
            raise CycleError("%s: action '%s' is a Cyclic Animation over frames %s–%s, but %s loops over its keys "
                             "%s–%s: key the first pose again at frame %s, or set the action's range to the keys"
                             % (name, action.name, num(a0), num(a1), prop, num(start), num(end), num(a1)))
    return Loop(start, end, offset)


def loop_of(target, action=None):
    """The Loop of a targets.Target's rotation channels in its current rotation mode, from `action`
    (default: its active action), or None (no modifiers, or no action). Raises CycleError as
    target_loop."""
    action = action if action is not None else fcurves.active_action(target.id_data)
    channels = fcurves.Channels.of(target.id_data, action) if action is not None else None
    if channels is None:
        return None
    mode = target.owner.rotation_mode
    prop, count = fcurves.rotation_property(mode)
    return target_loop(target.name, prop, channels.find_all(target.data_path(prop), count), mode, action)


def loop_of_keys(target, keys, action=None):
    """loop_of for a target whose targets.RotationKeys `keys` are read: None for NLA-evaluated keys,
    and None (not a CycleError) when no rotation channel has a Cycles modifier at all — other
    modifiers are then the reading task's to take or refuse, as for any open keys."""
    if keys.nla:
        return None
    try:
        return loop_of(target, action)
    except CycleError:
        if any("CYCLES" in kinds for kinds in keys.modifiers):
            raise
        return None


def channel_modes(target, action=None):
    """Per rotation channel of a loop's target (current mode), (mode_before, mode_after) of its Cycles
    modifier: what a rewrite of the loop's keys puts back. An unkeyed channel, which the rewrite keys,
    takes the first keyed channel's."""
    action = action if action is not None else fcurves.active_action(target.id_data)
    prop, count = fcurves.rotation_property(target.owner.rotation_mode)
    found = fcurves.Channels.of(target.id_data, action).find_all(target.data_path(prop), count)
    modes = [(f.modifiers[0].mode_before, f.modifiers[0].mode_after) if f is not None and len(f.modifiers)
             else None for f in found]
    first = next(m for m in modes if m is not None)
    return tuple(m or first for m in modes)
