"""The add-on fault table (issue 8): every bad situation a bake can meet, with the message the
animator gets and proof that no animation was lost.

Each case builds a scene, runs `bpy.ops.quatcurve.bake` and asserts
  * refused cases: the error report (naming object / bone / channel / frame), CANCELLED, and the
    whole file state unchanged — every action's digest (all F-curves: keys, handles,
    interpolation, modifiers), fake users, assignments, rotation modes, drivers;
  * baked cases: FINISHED, the note the report and panel carry (scene.quatcurve.last_lines), every
    action that existed before unchanged key for key (unless baking in place was asked for), and
    what Blender plays back afterwards.
"""

import math

import bpy
import numpy as np
import pytest

from bake_helpers import add_empty, add_rig, evaluated, file_state, key, select_bones, select_objects
from quatcurve_blender import fcurves, native

TOL = 2e-5  # rad: float32 key storage


# ---- state --------------------------------------------------------------------------------------------

def drivers_state():
    """Every driver F-curve of every object (path, index, expression, keys), as a digest."""
    out = {}
    for obj in bpy.data.objects:
        anim = obj.animation_data
        if anim is not None:
            out[obj.name] = sorted((d.data_path, d.array_index, d.driver.expression,
                                    fcurves.fcurve_digest(d).hexdigest()) for d in anim.drivers)
    return out


def whole_state():
    return file_state(), drivers_state()


def action_digests():
    return {a.name: fcurves.action_digest(a) for a in bpy.data.actions}


def refused(match, **kwargs):
    """The bake is refused with an error report matching `match` (raised as RuntimeError in
    background mode) and the file is unchanged."""
    before = whole_state()
    with pytest.raises(RuntimeError, match=match) as error:
        bpy.ops.quatcurve.bake(**kwargs)
    print("[fault] refused: %s" % str(error.value).strip())
    assert whole_state() == before, "a refused bake changed the file"


def baked(note=None, keep_actions=True, **kwargs):
    """The bake runs; `note` (a regex) must be in the report lines; every pre-existing action is
    unchanged when keep_actions. Returns scene.quatcurve."""
    before = action_digests()
    assert bpy.ops.quatcurve.bake(**kwargs) == {"FINISHED"}
    settings = bpy.context.scene.quatcurve
    text = settings.last_summary + "\n" + settings.last_lines
    print("[fault] baked: %s" % text.replace("\n", " | "))
    if note is not None:
        assert note_found(note, text), "expected the note %r in the bake report:\n%s" % (note, text)
    if keep_actions:
        after = action_digests()
        changed = [name for name, digest in before.items() if after.get(name) != digest]
        assert not changed, "the bake changed existing actions: %s" % changed
    return settings


def note_found(pattern, text):
    import re
    return re.search(pattern, text, re.S) is not None


@pytest.fixture
def cube(scene):
    """An empty 'Cube' in XYZ with LINEAR Euler keys at 1 and 11, selected."""
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (30, 0, 90))], degrees=True)
    select_objects(obj)
    return obj


def rotation_fcurve(owner, index, prop="rotation_euler"):
    """The F-curve of owner.prop[index] (owner: an object or a pose bone)."""
    return fcurves.Channels.of(owner.id_data).find(owner.path_from_id(prop), index)


def set_keys(fcurve, frames_values, interpolation="LINEAR"):
    """Replaces the F-curve's keys by exactly these (frame, value) pairs, in this order (duplicates
    kept: keyframe_insert would merge them)."""
    points = fcurve.keyframe_points
    while len(points):
        points.remove(points[0], fast=True)
    points.add(len(frames_values))
    points.foreach_set("co", np.array(frames_values, dtype=np.float32).ravel())
    for p in points:
        p.interpolation = interpolation


# ---- the table --------------------------------------------------------------------------------------

def test_nothing_selected(cube):
    select_objects()
    refused("Nothing to bake: no objects selected")


def test_nothing_selected_in_pose_mode(scene):
    rig = add_rig()
    key(rig.pose.bones["B0"], "rotation_quaternion", [(1, (1, 0, 0, 0)), (5, (0, 1, 0, 0))])
    select_bones(rig, set())
    refused("Nothing to bake: no pose bones selected")


def test_no_animation(scene):
    select_objects(add_empty("Still"))
    refused(r"Still: no rotation animation \(rotation mode XYZ, no keys on rotation_euler\)")


def test_only_some_channels_keyed_w_and_x(scene):
    """W and X keyed, Y and Z not: Blender plays Y and Z at their current values; the bake keeps
    exactly that and says which channels were held."""
    obj = add_empty("Cube", "QUATERNION")
    obj.rotation_quaternion = (1.0, 0.0, 0.3, 0.0)
    for frame, (w, x) in ((1, (1.0, 0.0)), (11, (0.5, 0.8))):
        obj.rotation_quaternion[0], obj.rotation_quaternion[1] = w, x
        obj.keyframe_insert("rotation_quaternion", index=0, frame=frame)
        obj.keyframe_insert("rotation_quaternion", index=1, frame=frame)
    for index in (0, 1):
        for p in rotation_fcurve(obj, index, "rotation_quaternion").keyframe_points:
            p.interpolation = "LINEAR"
    select_objects(obj)
    frames = np.arange(1, 12)
    before = evaluated(obj, frames)
    baked(r"Cube: rotation_quaternion\[2\], \[3\] not keyed.*held", method="QUAT_COMPONENTS")
    assert np.max(np.abs(np.abs(np.sum(evaluated(obj, frames) * before, axis=1)) - 1)) < 1e-6


def test_nan_keys(cube):
    set_keys(rotation_fcurve(cube, 1), [(1, 0.0), (11, math.nan)])
    refused(r"Cube: rotation_euler\[1\] is nan at frame 11")


def test_nan_keys_on_a_pose_bone(scene):
    rig = add_rig()
    bone = rig.pose.bones["B1"]
    key(bone, "rotation_quaternion", [(1, (1, 0, 0, 0)), (5, (0, 1, 0, 0))])
    set_keys(rotation_fcurve(bone, 2, "rotation_quaternion"), [(1, 0.0), (5, math.nan)])
    select_bones(rig, {"B1"})
    refused(r"Rig/B1: rotation_quaternion\[2\] is nan at frame 5")


def test_two_keys_on_one_frame_with_different_values(cube):
    """A jump at frame 11 (two keys there): no bake can keep it with one key per frame — refused,
    naming the channel, the frame and both values."""
    set_keys(rotation_fcurve(cube, 2), [(1, 0.0), (11, 0.5), (11, 1.5), (21, 1.0)])
    refused(r"Cube: rotation_euler\[2\] has 2 keys on frame 11 \(0\.5 and 1\.5\)")


def test_two_keys_on_one_frame_with_the_same_value_are_one_key(cube):
    set_keys(rotation_fcurve(cube, 2), [(1, 0.0), (11, 1.5), (11, 1.5), (21, 1.0)])
    frames = np.arange(1, 22)
    before = evaluated(cube, frames)
    baked(method="EULER")
    after = evaluated(cube, frames)
    assert np.max(np.abs(np.abs(np.sum(after * before, axis=1)) - 1)) < 1e-6


def _library_object(tmp_path):
    """'Linked', an animated empty written to a library .blend and linked back into the scene."""
    source = add_empty("Linked", "XYZ")
    key(source, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    library_file = str(tmp_path / "library.blend")
    bpy.data.libraries.write(library_file, {source}, fake_user=True)
    action = fcurves.active_action(source)
    bpy.data.objects.remove(source)
    bpy.data.actions.remove(action)
    with bpy.data.libraries.load(library_file, link=True) as (data_from, data_to):
        data_to.objects = ["Linked"]
    linked = data_to.objects[0]
    assert linked.library is not None
    bpy.context.scene.collection.objects.link(linked)
    return linked


def test_library_linked_object(scene, tmp_path):
    select_objects(_library_object(tmp_path))
    refused("Linked: the object is library-linked and cannot be changed")


def test_library_override(scene, tmp_path):
    override = _library_object(tmp_path).override_create(remap_local_usages=True)
    assert override.override_library is not None
    select_objects(override)
    refused("Linked: the object is override-protected and cannot be changed")


def test_library_linked_action_in_place(scene, tmp_path):
    """A local object playing a linked action: in place is refused; into a new action it bakes."""
    source = add_empty("Source", "XYZ")
    key(source, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    action = fcurves.active_action(source)
    action.name = "LibAction"
    library_file = str(tmp_path / "actions.blend")
    bpy.data.libraries.write(library_file, {action}, fake_user=True)
    bpy.data.objects.remove(source)
    bpy.data.actions.remove(action)
    with bpy.data.libraries.load(library_file, link=True) as (data_from, data_to):
        data_to.actions = ["LibAction"]
    obj = add_empty("Cube", "XYZ")
    fcurves.assign_action(obj, data_to.actions[0])
    if fcurves.SLOTTED and obj.animation_data.action_slot is None:
        obj.animation_data.action_slot = data_to.actions[0].slots[0]
    select_objects(obj)
    refused("Cube: action 'LibAction' is library-linked and cannot be changed in place", new_action=False)
    baked(new_action=True)
    assert fcurves.active_action(obj).library is None


@pytest.mark.parametrize("new_action", [True, False], ids=["new_action", "in_place"])
def test_action_shared_by_two_objects(scene, new_action):
    """Baking Cube must not change Other, which plays the same action: Cube gets its own new action
    (also when baking in place was asked for, and the report says so)."""
    cube = add_empty("Cube", "XYZ")
    key(cube, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    shared = fcurves.active_action(cube)
    shared.name = "Shared"
    other = add_empty("Other", "XYZ")
    fcurves.assign_action(other, shared)
    if fcurves.SLOTTED and other.animation_data.action_slot is None:
        other.animation_data.action_slot = cube.animation_data.action_slot
    frames = np.arange(1, 12)
    other_before = evaluated(other, frames)
    select_objects(cube)
    note = None if new_action else r"Cube: action 'Shared' is also used by Other.*new action"
    baked(note, keep_actions=True, method="SQUAD", rotation_mode="QUATERNION", new_action=new_action)
    assert fcurves.active_action(other) == shared
    assert fcurves.active_action(cube) != shared
    assert np.max(np.abs(evaluated(other, frames) - other_before)) < 1e-7
    assert other.rotation_mode == "XYZ"


def _nla_cube():
    """'Cube' (XYZ): an NLA strip turns Z 0→90° over 1..11 (LINEAR); the active action turns X
    0→30°. Blender plays X from the action and Z from the strip."""
    obj = add_empty("Cube", "XYZ")
    key(obj, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    strip_action = fcurves.active_action(obj)
    strip_action.name = "StripAction"
    slot = obj.animation_data.action_slot if fcurves.SLOTTED else None
    obj.animation_data.action = None
    track = obj.animation_data.nla_tracks.new()
    strip = track.strips.new("Strip", 1, strip_action)
    if fcurves.SLOTTED and getattr(strip, "action_slot", None) is None and slot is not None:
        strip.action_slot = slot
    obj.rotation_euler = (0, 0, 0)
    obj.keyframe_insert("rotation_euler", index=0, frame=1)
    obj.rotation_euler[0] = math.radians(30)
    obj.keyframe_insert("rotation_euler", index=0, frame=11)
    for p in rotation_fcurve(obj, 0).keyframe_points:
        p.interpolation = "LINEAR"
    return obj


def test_nla_strips_present_bake_the_evaluated_result(scene):
    obj = _nla_cube()
    select_objects(obj)
    frames = np.arange(1, 12)
    before = evaluated(obj, frames)
    assert abs(math.degrees(evaluated(obj, [11], "values")[0][2]) - 90) < 1e-3  # Z comes from the strip
    baked(r"Cube: NLA.*evaluated", method="EULER")
    after = evaluated(obj, frames)
    assert np.max(np.abs(np.abs(np.sum(after * before, axis=1)) - 1)) < 1e-6


def test_fcurve_modifiers(cube):
    """A Noise modifier on Z: Blender's evaluation (modifier included) is read at the key frames;
    the report says the modifier's motion between keys is not kept."""
    modifier = rotation_fcurve(cube, 2).modifiers.new("NOISE")
    modifier.strength, modifier.scale = 0.5, 2.0
    value_at_11 = evaluated(cube, [11], "values")[0]
    baked(r"Cube: rotation_euler\[2\].*modifier.*NOISE", method="SLERP")
    # The baked key at frame 11 is Blender's evaluation there, noise included.
    assert np.max(np.abs(evaluated(cube, [11], "values")[0] - value_at_11)) < 1e-4


def test_driver_on_rotation_is_refused(cube):
    """A driver overrides whatever keys a bake writes: refused, naming the driven channel."""
    driver = cube.driver_add("rotation_euler", 2).driver
    driver.type = "SCRIPTED"
    driver.expression = "0.5"
    refused(r"Cube: rotation_euler\[2\] is driven by a driver")


def test_constraints(cube):
    """Constraints act on top of the rotation channels: the bake writes the channels (not the
    constrained, visual result) and says that the constraints still apply."""
    constraint = cube.constraints.new("LIMIT_ROTATION")
    constraint.use_limit_z, constraint.max_z = True, math.radians(45)
    frames = np.arange(1, 12)
    channels_before = evaluated(cube, frames, "values")
    baked(r"Cube: constraints? \(Limit Rotation\).*still appl", method="EULER")
    assert np.max(np.abs(evaluated(cube, frames, "values") - channels_before)) < TOL


def test_frame_range_of_a_hundred_million_frames(cube):
    refused(r"frame range 1\.\.100000001 is 100000000 frames long: at most 10,000,000 frames",
            frame_start=1, frame_end=100_000_001)


def test_step_zero(cube):
    refused("step 0: must be at least 1 frame", step=0)


def test_negative_tolerance(cube):
    refused("tolerance -1°: must be 0 or more", tolerance=-1.0)


def test_native_module_missing(cube, monkeypatch):
    monkeypatch.setattr(native, "module", None)
    monkeypatch.setattr(native, "UNAVAILABLE_REASON", "simulated: the compiled module is missing")
    refused("quatcurve is unavailable: simulated: the compiled module is missing")


# ---- fit (quatcurve.fit, fit.fit): the same bad inputs, refused before anything is written -----------

def fit_records():
    """Every action's fit and ease records (the fit writes them with the keys)."""
    return {a.name: ([(r.slot, r.owner_path, r.method, r.signature) for r in getattr(a, "quatcurve_fits", ())],
                     [(e.owner_path, e.frame) for e in getattr(a, "quatcurve_eases", ())]) for a in bpy.data.actions}


def fit_refused(match, settings=None):
    """The fit is refused with a message matching `match` — through the operator (RuntimeError in
    background mode), or through fit.fit with `settings` (FitError) — and the file (keys, handles,
    key types, records) is unchanged."""
    from quatcurve_blender import fit, targets
    before = whole_state(), fit_records()
    if settings is None:
        with pytest.raises(RuntimeError, match=match) as error:
            bpy.ops.quatcurve.fit(method="SQUAD", tolerance=0.05)
    else:
        with pytest.raises(fit.FitError, match=match) as error:
            fit.fit(targets.gather_targets(bpy.context, verb="fit"), settings)
    print("[fault] fit refused: %s" % str(error.value).strip())
    assert (whole_state(), fit_records()) == before, "a refused fit changed the file"


def test_fit_nan_key(cube):
    set_keys(rotation_fcurve(cube, 1), [(1, 0.0), (11, math.nan)])
    fit_refused(r"Cube: rotation_euler\[1\] is nan at frame 11")


def test_fit_nan_key_on_a_pose_bone(scene):
    rig = add_rig()
    bone = rig.pose.bones["B1"]
    key(bone, "rotation_quaternion", [(1, (1, 0, 0, 0)), (5, (0, 1, 0, 0))])
    set_keys(rotation_fcurve(bone, 2, "rotation_quaternion"), [(1, 0.0), (5, math.nan)])
    select_bones(rig, {"B1"})
    fit_refused(r"Rig/B1: rotation_quaternion\[2\] is nan at frame 5")


def test_fit_two_keys_on_one_frame(cube):
    set_keys(rotation_fcurve(cube, 2), [(1, 0.0), (11, 0.5), (11, 1.5), (21, 1.0)])
    fit_refused(r"Cube: rotation_euler\[2\] has two different keys on frame 11 \(0\.5 and 1\.5\)")


def test_fit_library_linked_object(scene, tmp_path):
    select_objects(_library_object(tmp_path))
    fit_refused("Linked: the object is library-linked and cannot be changed")


def test_fit_library_override(scene, tmp_path):
    override = _library_object(tmp_path).override_create(remap_local_usages=True)
    select_objects(override)
    fit_refused("Linked: the object is override-protected and cannot be changed")


def test_fit_library_linked_action(scene, tmp_path):
    """Fit always works in place: a linked action is refused (a bake could write a new action)."""
    source = add_empty("Source", "XYZ")
    key(source, "rotation_euler", [(1, (0, 0, 0)), (11, (0, 0, 90))], degrees=True)
    action = fcurves.active_action(source)
    action.name = "LibAction"
    library_file = str(tmp_path / "actions.blend")
    bpy.data.libraries.write(library_file, {action}, fake_user=True)
    bpy.data.objects.remove(source)
    bpy.data.actions.remove(action)
    with bpy.data.libraries.load(library_file, link=True) as (data_from, data_to):
        data_to.actions = ["LibAction"]
    obj = add_empty("Cube", "XYZ")
    fcurves.assign_action(obj, data_to.actions[0])
    if fcurves.SLOTTED and obj.animation_data.action_slot is None:
        obj.animation_data.action_slot = data_to.actions[0].slots[0]
    select_objects(obj)
    fit_refused("Cube: action 'LibAction' is library-linked and cannot be changed in place")


def test_fit_driver_on_rotation(cube):
    cube.driver_add("rotation_euler", 2).driver.expression = "0.5"
    fit_refused(r"Cube: rotation_euler\[2\] is driven by a driver")


@pytest.mark.parametrize("tolerance", [0.0, -1.0, math.nan], ids=["zero", "negative", "nan"])
def test_fit_tolerance_not_above_zero(cube, tolerance):
    """The operator's tolerance property has a minimum above 0; fit.fit itself refuses the rest."""
    from quatcurve_blender import fit
    fit_refused(r"tolerance .*°: must be a finite angle above 0", fit.FitSettings(tolerance=tolerance))


def test_fit_axis_angle_zero_axis(scene):
    """Axis-angle is fitted, but a key whose axis is zero defines no rotation axis: refused, naming
    the channels and the frame."""
    obj = add_empty("Cube", "AXIS_ANGLE")
    key(obj, "rotation_axis_angle", [(1, (0, 0, 0, 1)), (11, (2, 0, 0, 0)), (21, (3, 0, 0, 1))])
    select_objects(obj)
    fit_refused(r"Cube: rotation_axis_angle\[1\.\.3\] \(the axis\) is zero at frame 11")
