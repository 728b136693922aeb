"""Fit on real inputs, in every Blender where the bundled add-on runs (skipped with the reason elsewhere).

glTF: a scene (an object and a 2-bone rig, quaternion keys 100°–130° apart) exported with Blender's
bundled glTF exporter as sparse LINEAR rotation samplers (no sampling), imported into a fresh file:
the importer keys them as LINEAR quaternion F-curves — component-wise, nlerp — although glTF
specifies slerp. After fit.fit(SLERP) Blender must play what the file specifies: its evaluation at
every frame and 4 subframes is compared with a slerp (numpy, glTF's own formula, shortest arc)
between the sampler's keyframes read from the .gltf JSON and its buffer.

Rigify: a human meta-rig generated with the bundled Rigify; several controls (quaternion and Euler
orders mixed) keyed far apart, fitted together in Pose mode with the operator; each control's
evaluation checked against the native curve, the animator keys unchanged."""

import base64
import json
import math
import os
import time

import bpy
import numpy as np
import pytest
from mathutils import Euler, Quaternion

from bake_helpers import angles_between, rotation_quat, select_bones
from quatcurve_blender import fcurves, fit, native
from quatcurve_blender.targets import Target

TOL = 0.05  # degrees


_ENABLED = []


def enable_bundled(module, default_set=False):
    """Enables a bundled add-on (again after read_factory_settings); the reason when it cannot.
    Rigify's register() reads its own preferences: it needs default_set=True (listed in them).
    Disabled again after the test (bundled_addons), so later tests run without it."""
    import addon_utils
    try:
        mod = addon_utils.enable(module, default_set=default_set)
    except Exception as error:  # noqa: BLE001 — any failure is a reason to skip
        return "%s could not be enabled: %s" % (module, error)
    if mod is not None:
        _ENABLED.append((module, default_set))
    return "" if mod is not None else "%s is not available in Blender %s" % (module, bpy.app.version_string)


@pytest.fixture(autouse=True)
def bundled_addons():
    yield
    import addon_utils
    while _ENABLED:
        module, default_set = _ENABLED.pop()
        try:
            addon_utils.disable(module, default_set=default_set)
        except Exception as error:  # noqa: BLE001 — cleanup only
            print("[cleanup] %s not disabled: %s" % (module, error))


def operator_missing(op):
    try:
        op.get_rna_type()
    except (KeyError, AttributeError) as error:
        return "operator missing: %s" % error
    return ""


def key_quats(owner, frames_quats):
    for frame, (axis, degrees) in frames_quats:
        owner.rotation_quaternion = Quaternion(axis, math.radians(degrees))
        owner.keyframe_insert("rotation_quaternion", frame=frame)
    for curve in fcurves.Channels.of(owner.id_data).find_all(owner.path_from_id("rotation_quaternion"), 4):
        for p in curve.keyframe_points:
            p.interpolation = "LINEAR"


# Keys 100°-250° of turn apart, about changing axes: nlerp and slerp differ by degrees.
OBJ_KEYS = [(1, ((1, 0, 0), 0)), (11, ((0, 0, 1), 120)), (31, ((1, 1, 0), 240)), (41, ((0, 1, 1), 100)),
            (61, ((1, 0, 1), 300))]
BONE_KEYS = [(1, ((1, 0, 0), 10)), (21, ((0, 1, 0), 130)), (41, ((1, 0, 1), 250)), (51, ((0, 1, 1), 120)),
             (71, ((1, 1, 1), 0))]


def build_gltf_scene():
    scene = bpy.context.scene
    obj = bpy.data.objects.new("Obj", None)
    scene.collection.objects.link(obj)
    obj.rotation_mode = "QUATERNION"
    key_quats(obj, OBJ_KEYS)
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    rig.select_set(True)
    bpy.ops.object.mode_set(mode="EDIT")
    b0 = rig.data.edit_bones.new("B0")
    b0.head, b0.tail = (0, 0, 0), (0, 0, 1)
    b1 = rig.data.edit_bones.new("B1")
    b1.head, b1.tail, b1.parent = (0, 0, 1), (0, 0.5, 2), b0
    bpy.ops.object.mode_set(mode="OBJECT")
    for name in ("B0", "B1"):
        pb = rig.pose.bones[name]
        pb.rotation_mode = "QUATERNION"
        key_quats(pb, BONE_KEYS)
    scene.frame_start, scene.frame_end = 1, 71


def read_gltf_rotations(path):
    """{node name: (times (K,) seconds, quaternions (K, 4) w, x, y, z, interpolation)} of every
    rotation channel in the .gltf (JSON + its buffers)."""
    with open(path) as f:
        doc = json.load(f)
    buffers = []
    for buf in doc["buffers"]:
        uri = buf["uri"]
        if uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(path), uri), "rb") as f:
                buffers.append(f.read())

    def accessor(i):
        acc = doc["accessors"][i]
        assert acc["componentType"] == 5126, "float accessors only"  # FLOAT
        width = {"SCALAR": 1, "VEC4": 4}[acc["type"]]
        view = doc["bufferViews"][acc["bufferView"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        stride = view.get("byteStride", 4 * width)
        raw = buffers[view["buffer"]]
        rows = [np.frombuffer(raw, "<f4", width, start + r * stride) for r in range(acc["count"])]
        return np.array(rows, dtype=np.float64).reshape(acc["count"], width)

    out = {}
    for anim in doc.get("animations", []):
        for channel in anim["channels"]:
            if channel["target"]["path"] != "rotation":
                continue
            sampler = anim["samplers"][channel["sampler"]]
            xyzw = accessor(sampler["output"])
            out[doc["nodes"][channel["target"]["node"]]["name"]] = (
                accessor(sampler["input"])[:, 0], xyzw[:, [3, 0, 1, 2]], sampler.get("interpolation", "LINEAR"))
    return out


def gltf_slerp(times, quats, at):
    """glTF's LINEAR rotation: slerp between neighbouring keyframes, the shorter arc (the spec's
    s = sign(dot)), held outside the keyed times."""
    at = np.clip(at, times[0], times[-1])
    k = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 2)
    a, b = quats[k], quats[k + 1]
    u = ((at - times[k]) / (times[k + 1] - times[k]))[:, None]
    d = np.sum(a * b, axis=1, keepdims=True)
    b = np.where(d < 0, -b, b)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1, 1))
    small = theta < 1e-9
    s = np.where(small, 1.0, np.sin(theta))
    wa = np.where(small, 1 - u, np.sin((1 - u) * theta) / s)
    wb = np.where(small, u, np.sin(u * theta) / s)
    q = wa * a + wb * b
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def change_of_frame(file_quats, blender_quats):
    """The orthogonal 4×4 M with blender_quats[k] = ±M·file_quats[k] for every key (least squares,
    the key signs searched), or None when there is none."""
    K = len(file_quats)
    for bits in range(2 ** (K - 1)):
        signs = np.array([1.0] + [(-1.0 if bits >> k & 1 else 1.0) for k in range(K - 1)])
        target = blender_quats * signs[:, None]
        M = target.T @ np.linalg.pinv(file_quats.T)
        if np.abs(M.T @ M - np.eye(4)).max() < 1e-4 and np.abs(file_quats @ M.T - target).max() < 1e-5:
            return M
    return None


def play_the_imported_action(obj):
    """Fit works on the action a target plays as its active action. Blender's importer puts each
    glTF animation in an NLA track of its own, and makes an action active only for some objects
    (3.4–5.0: the first; the rig gets only the strip). The strip's action becomes active and the
    track is removed: the object plays the same action, now editable. Returns what was done."""
    anim = obj.animation_data
    if anim is None:
        return ""
    strips = [(t, s) for t in anim.nla_tracks for s in t.strips]
    if len(strips) != 1:
        return "%d strips left as they are" % len(strips)
    track, strip = strips[0]
    action, slot = strip.action, getattr(strip, "action_slot", None)
    if anim.action is None:
        anim.action = action
        if fcurves.SLOTTED and slot is not None:
            anim.action_slot = slot
        done = "strip action made active"
    else:
        assert anim.action == action, (anim.action, action)
        done = "active already"
    anim.nla_tracks.remove(track)
    return done + ", NLA track removed"


def played_quats(owners, times):
    scene, out = bpy.context.scene, {id(o): [] for o in owners}
    for t in times:
        scene.frame_set(int(math.floor(t)), subframe=float(t - math.floor(t)))
        for o in owners:
            out[id(o)].append(tuple(rotation_quat(o)))
    return {k: np.array(q) for k, q in out.items()}


def test_gltf_linear_rotations_play_as_the_file_specifies_after_a_slerp_fit(scene, tmp_path):
    reason = enable_bundled("io_scene_gltf2") or operator_missing(bpy.ops.export_scene.gltf)
    if reason:
        pytest.skip("glTF: " + reason)
    build_gltf_scene()
    path = str(tmp_path / "scene.gltf")
    assert bpy.ops.export_scene.gltf(filepath=path, export_format="GLTF_SEPARATE", export_animations=True,
                                     export_force_sampling=False, export_optimize_animation_size=False) == {"FINISHED"}
    in_file = read_gltf_rotations(path)
    assert sorted(in_file) == ["B0", "B1", "Obj"], sorted(in_file)
    for name, (times, quats, interpolation) in in_file.items():
        assert interpolation == "LINEAR" and len(times) == 5, (name, interpolation, len(times))  # sparse

    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert not enable_bundled("io_scene_gltf2")
    assert bpy.ops.import_scene.gltf(filepath=path) == {"FINISHED"}
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    rig, obj = bpy.data.objects["Rig"], bpy.data.objects["Obj"]
    notes = {o.name: play_the_imported_action(o) for o in (obj, rig)}
    print("[gltf] Blender %s import: %s" % (bpy.app.version_string, notes))
    owners = {"Obj": obj, "B0": rig.pose.bones["B0"], "B1": rig.pose.bones["B1"]}
    found = [Target(obj), Target(rig, "B0"), Target(rig, "B1")]

    # What the importer wrote: the file's keyframes as LINEAR quaternion keys at frame = fps·t + offset.
    imported, mapping = {}, {}
    for name, owner in owners.items():
        assert owner.rotation_mode == "QUATERNION"
        keys = fit.read_animator_keys(Target(rig, name) if owner is not obj else Target(obj))
        curves = [c for c in fcurves.Channels.of(owner.id_data).find_all(keys.path, 4) if c is not None]
        assert len(curves) == 4 and all(p.interpolation == "LINEAR" for c in curves for p in c.keyframe_points)
        times, quats, _ = in_file[name]
        offset = keys.frames[0] - fps * times[0]
        np.testing.assert_allclose(keys.frames, fps * times + offset, atol=1e-3)
        # The importer's change of frame (Y-up → Z-up, bone rest) is constant and linear on
        # quaternions: Blender's key values = M · the file's, M orthogonal (least squares on the keys).
        # The importer's change of frame (Y-up → Z-up, bone rest) is constant and linear on
        # quaternions: Blender's key values = ±M · the file's (the importer picks each key's sign),
        # M orthogonal. M is fitted on the keys (least squares, over the key signs).
        M = change_of_frame(quats, keys.values)
        assert M is not None, "%s: the imported keys are no fixed change of frame of the file's" % name
        imported[name], mapping[name] = keys.values.copy(), (M, offset, keys.frames.copy())

    first = min(m[2][0] for m in mapping.values())
    last = max(m[2][-1] for m in mapping.values())
    check = np.arange(math.ceil(first * 4), math.floor(last * 4) + 1) / 4.0

    def errors():
        played = played_quats(list(owners.values()), check)
        out = {}
        for name, owner in owners.items():
            M, offset, frames = mapping[name]
            times, quats, _ = in_file[name]
            want = gltf_slerp(times, quats, (check - offset) / fps) @ M.T
            out[name] = np.degrees(angles_between(played[id(owner)], want)).max()
        return out

    before = errors()
    print("[gltf] before the fit (Blender's nlerp), max error: %s" % {k: round(v, 3) for k, v in before.items()})
    assert max(before.values()) > 1.0, "the keys are too close for nlerp and slerp to differ: %s" % before

    result = fit.fit(found, fit.FitSettings(method="SLERP", tolerance=TOL))
    print("[gltf] %s | %s" % (result.summary(), " | ".join(result.lines())))
    after = errors()
    print("[gltf] after fit(SLERP), max error: %s" % {k: round(v, 4) for k, v in after.items()})
    for name, owner in owners.items():
        keys = fit.read_animator_keys(found[list(owners).index(name)])
        np.testing.assert_array_equal(keys.frames, mapping[name][2])  # the importer's keys stay
        np.testing.assert_array_equal(np.abs(keys.values), np.abs(imported[name]))  # signs may flip
        assert after[name] <= TOL + 1e-4, "%s: %.5f° from the file's slerp" % (name, after[name])


# ---- Rigify ---------------------------------------------------------------------------------------------

def generate_rigify_rig():
    """A human meta-rig generated with Rigify; returns (rig, seconds) or raises pytest.skip."""
    reason = enable_bundled("rigify", default_set=True) or operator_missing(bpy.ops.pose.rigify_generate)
    if reason:
        pytest.skip("Rigify: " + reason)
    start = time.perf_counter()
    bpy.ops.object.armature_human_metarig_add()
    metarig = bpy.context.active_object
    bpy.ops.object.mode_set(mode="POSE")
    try:
        bpy.ops.pose.rigify_generate()
    except RuntimeError as error:
        pytest.skip("Rigify generation failed in Blender %s: %s" % (bpy.app.version_string,
                                                                   " ".join(str(error).split())[:300]))
    seconds = time.perf_counter() - start
    if bpy.context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    rig = next(o for o in bpy.data.objects if o.type == "ARMATURE" and o != metarig and "rig" in o.name.lower())
    metarig.hide_set(True)
    return rig, seconds


# Controls and keys (degrees for Euler, (axis, degrees) for quaternions), whatever mode Rigify gave.
RIGIFY_KEYS = [(1, (0, 0, 0)), (15, (80, -40, 30)), (35, (-60, 70, 120)), (50, (20, 10, -90))]


def test_rigify_controls_with_mixed_modes_fit_together(scene):
    rig, seconds = generate_rigify_rig()
    if seconds > 60:
        pytest.skip("Rigify generation took %.0f s (> 60 s) in Blender %s" % (seconds, bpy.app.version_string))
    # Rigify's own rotation modes: quaternion controls, YXZ shoulders, ZXY and YZX controls elsewhere.
    wanted = ["torso", "chest", "head", "upper_arm_fk.L", "hand_ik.R", "foot_ik.L", "shoulder.L"]
    controls = [rig.pose.bones[n] for n in wanted if n in rig.pose.bones]
    for mode in ("ZXY", "YZX"):
        controls += [pb for pb in rig.pose.bones if pb.rotation_mode == mode
                     and not pb.name.startswith(("ORG-", "DEF-", "MCH-"))][:1]
    modes = {pb.name: pb.rotation_mode for pb in controls}
    assert len(controls) >= 7 and len(set(modes.values())) >= 3, modes
    for pb in controls:
        for frame, angles in RIGIFY_KEYS:
            if pb.rotation_mode == "QUATERNION":
                pb.rotation_quaternion = Euler([math.radians(a) for a in angles], "XYZ").to_quaternion()
                pb.keyframe_insert("rotation_quaternion", frame=frame)
            else:
                pb.rotation_euler = [math.radians(a) for a in angles]
                pb.keyframe_insert("rotation_euler", frame=frame)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="POSE")
    select_bones(rig, {pb.name for pb in controls})
    before = {pb.name: fit.read_animator_keys(Target(rig, pb.name)) for pb in controls}
    assert bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL) == {"FINISHED"}
    lines = bpy.context.scene.quatcurve_fit.last_lines
    print("[rigify] Blender %s, generated in %.1f s; modes %s\n%s" % (bpy.app.version_string, seconds, modes, lines))
    times = np.arange(4, 50 * 4 + 1) / 4.0
    played = played_quats(controls, times)
    qc = native.require()
    for pb in controls:
        old, new = before[pb.name], fit.read_animator_keys(Target(rig, pb.name))
        np.testing.assert_array_equal(old.frames, new.frames)
        if pb.rotation_mode == "QUATERNION":
            np.testing.assert_array_equal(np.abs(old.values), np.abs(new.values))
            curve = qc.Curve(old.frames, old.values, "SQUAD")
        else:
            np.testing.assert_array_equal(old.values, new.values)
            curve = qc.Curve.from_euler(old.frames, old.values, order=pb.rotation_mode, method="SQUAD")
        err = np.degrees(angles_between(played[id(pb)], curve.sample(times))).max()
        assert err <= TOL + 1e-4, "%s (%s): %.5f°" % (pb.name, pb.rotation_mode, err)
