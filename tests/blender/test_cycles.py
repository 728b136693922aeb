"""Which rotation targets are loops (cycles.py): Blender's own cyclic form, and every other modifier
setup refused naming the target, the channel and the modifier."""

import bpy
import pytest

from bake_helpers import add_empty, key, rotation_fcurves
from quatcurve_blender import cycles


def looping(obj, prop="rotation_euler", count=3, keys=((1, (0, 0, 0)), (9, (0.5, 0.2, 0.1)), (25, (0, 0, 0))),
            mode_before="REPEAT", mode_after="REPEAT"):
    key(obj, prop, keys)
    curves = sorted(rotation_fcurves(obj, prop), key=lambda f: f.array_index)
    for curve in curves:
        m = curve.modifiers.new("CYCLES")
        m.mode_before, m.mode_after = mode_before, mode_after
    return curves


def loop_of(obj, curves, prop="rotation_euler"):
    action = obj.animation_data.action
    return cycles.target_loop(obj.name, prop, curves, obj.rotation_mode, action)


def test_open_keys_are_no_loop(scene):
    obj = add_empty("Open", "XYZ")
    key(obj, "rotation_euler", ((1, (0, 0, 0)), (9, (0.5, 0.2, 0.1))))
    assert loop_of(obj, rotation_fcurves(obj, "rotation_euler")) is None


def test_repeat_on_every_channel_is_a_loop_of_the_keys_period(scene):
    obj = add_empty("Walk", "XYZ")
    curves = looping(obj)
    loop = loop_of(obj, curves)
    assert (loop.start, loop.end, loop.period, loop.offset) == (1.0, 25.0, 24.0, False)


def test_repeat_with_offset_is_a_euler_wheel_and_refused_on_quaternions(scene):
    wheel = add_empty("Wheel", "XYZ")
    curves = looping(wheel, keys=((1, (0, 0, 0)), (25, (0, 0, 6.283185307))), mode_after="REPEAT_OFFSET")
    assert loop_of(wheel, curves).offset
    q = add_empty("Q", "QUATERNION")
    curves = looping(q, "rotation_quaternion", 4, keys=((1, (1, 0, 0, 0)), (25, (1, 0, 0, 0))),
                     mode_before="REPEAT_OFFSET", mode_after="REPEAT_OFFSET")
    with pytest.raises(cycles.CycleError, match=r"Q: rotation_quaternion\[0\] has a Cycles modifier in Repeat with Offset"):
        loop_of(q, curves, "rotation_quaternion")


@pytest.mark.parametrize("case, message", [
    ("mirror", r"Bad: rotation_euler\[0\] has a Cycles modifier in modes MIRROR/MIRROR"),
    ("muted", r"Bad: rotation_euler\[0\] has a muted Cycles modifier"),
    ("range", r"Bad: rotation_euler\[0\] has a Cycles modifier with a restricted frame range"),
    ("influence", r"Bad: rotation_euler\[0\] has a Cycles modifier with an influence"),
    ("count", r"Bad: rotation_euler\[0\] has a Cycles modifier with a finite count \(before 0, after 2\)"),
    ("noise", r"Bad: rotation_euler\[0\] has F-curve modifiers \(NOISE\)"),
    ("after", r"Bad: rotation_euler\[0\] has F-curve modifiers after its Cycles modifier \(NOISE\)"),
    ("some", r"Bad: rotation_euler\[1\] has a Cycles modifier and rotation_euler\[0\] none"),
    ("periods", r"Bad: rotation_euler\[0\] loops over frames 1–25 and rotation_euler\[2\] over 1–20"),
    ("range_action", r"Bad: action '.*' is a Cyclic Animation over frames 1–30, but rotation_euler loops over its "
                     r"keys 1–25: key the first pose again at frame 30"),
])
def test_what_is_not_blenders_cyclic_form_is_refused_naming_channel_and_modifier(scene, case, message):
    obj = add_empty("Bad", "XYZ")
    if case == "noise":
        key(obj, "rotation_euler", ((1, (0, 0, 0)), (25, (0, 0, 0))))
        curves = rotation_fcurves(obj, "rotation_euler")
        curves[0].modifiers.new("NOISE")
    elif case == "some":
        key(obj, "rotation_euler", ((1, (0, 0, 0)), (25, (0, 0, 0))))
        curves = rotation_fcurves(obj, "rotation_euler")
        curves[1].modifiers.new("CYCLES")
    else:
        curves = looping(obj)
        m = curves[0].modifiers[0]
        if case == "mirror":
            m.mode_before = m.mode_after = "MIRROR"
        elif case == "muted":
            m.mute = True
        elif case == "range":
            m.use_restricted_range = True
        elif case == "influence":
            m.use_influence = True
        elif case == "count":
            m.cycles_after = 2
        elif case == "after":
            curves[0].modifiers.new("NOISE")
        elif case == "periods":
            curves[2].keyframe_points[-1].co[0] = 20
            curves[2].update()
        elif case == "range_action":
            action = obj.animation_data.action
            action.use_frame_range = True
            action.frame_start, action.frame_end = 1, 30
            action.use_cyclic = True
    with pytest.raises(cycles.CycleError, match=message):
        loop_of(obj, curves)


def test_cyclic_animation_range_matching_the_keys_is_the_period(scene):
    obj = add_empty("Ranged", "XYZ")
    curves = looping(obj)
    action = obj.animation_data.action
    action.use_frame_range = True
    action.frame_start, action.frame_end = 1, 25
    action.use_cyclic = True
    assert loop_of(obj, curves).period == 24.0
