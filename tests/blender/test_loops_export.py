"""Loops through the tasks that write or export (bake, reduce, glTF, the CLI): a target whose rotation
channels carry Blender's plain Cycles modifier (cycles.py) is baked and reduced as one period with the
modifier on the written channels, and exported to glTF as one period whose first and last keys are
equal. Blender's playback is checked over three periods, before and after the keyed range; the .glb,
read with no code of ours and played per the glTF specification (test_gltf.py), over two periods of
wrapped time.

Scenes: a quaternion loop, an Euler loop with uneven key spacing, an Euler wheel repeating with
offset (0° → 360° per period), a rig whose bones loop with their own periods."""

import math

import bpy
import numpy as np
import pytest
from mathutils import Quaternion

from bake_helpers import add_empty, add_rig, angles_between, key, rotation_fcurves, select_bones, select_objects
from everywhere_scenes import euler_keys, quaternion_keys
from test_gltf import FPS, GltfFile, angle, gltf_world
from quatcurve_blender import bake, cycles, gltf, native, reduce, targets

QUAT_LOOP = quaternion_keys(((1, ((1, 0, 0), 0)), (7, ((0, 0, 1), 70)), (13, ((1, 1, 0), 140)),
                             (19, ((0, 1, 1), 60)), (25, ((1, 0, 0), 0))))
EULER_UNEVEN = euler_keys("XYZ", ((1, (10, -20, 30)), (4, (60, 10, -40)), (13, (-30, 45, 80)),
                                  (17, (20, 5, 10)), (31, (10, -20, 30))))
WHEEL = euler_keys("XYZ", ((1, (0, 0, 0)), (9, (0, 0, 120)), (17, (0, 0, 240)), (25, (0, 0, 360))))
BONE_QUAT = quaternion_keys(((1, ((0, 1, 0), 10)), (11, ((1, 0, 0), 80)), (21, ((0, 1, 0), 10))))
BONE_EULER = euler_keys("XYZ", ((1, (0, 0, 0)), (6, (40, 0, 20)), (16, (-30, 20, 0)), (31, (0, 0, 0))))


def make_cyclic(owner, prop, mode="REPEAT"):
    for curve in rotation_fcurves(owner, prop):
        m = curve.modifiers.new("CYCLES")
        m.mode_before = m.mode_after = mode


def loop_scene():
    """{name: (owner, target)} of the four loops."""
    found = {}
    quat = add_empty("QuatLoop", "QUATERNION")
    key(quat, "rotation_quaternion", QUAT_LOOP)
    make_cyclic(quat, "rotation_quaternion")
    found["QuatLoop"] = (quat, targets.Target(quat))
    euler = add_empty("EulerLoop", "XYZ")
    key(euler, "rotation_euler", EULER_UNEVEN)
    make_cyclic(euler, "rotation_euler")
    found["EulerLoop"] = (euler, targets.Target(euler))
    wheel = add_empty("Wheel", "XYZ")
    key(wheel, "rotation_euler", WHEEL)
    make_cyclic(wheel, "rotation_euler", "REPEAT_OFFSET")
    found["Wheel"] = (wheel, targets.Target(wheel))
    rig = add_rig("Rig", bones=("A", "B"), rotation_mode="QUATERNION")
    rig.pose.bones["B"].rotation_mode = "XYZ"
    key(rig.pose.bones["A"], "rotation_quaternion", BONE_QUAT)
    make_cyclic(rig.pose.bones["A"], "rotation_quaternion")
    key(rig.pose.bones["B"], "rotation_euler", BONE_EULER)
    make_cyclic(rig.pose.bones["B"], "rotation_euler")
    bpy.ops.object.mode_set(mode="OBJECT")
    found["Rig/A"] = (rig.pose.bones["A"], targets.Target(rig, "A"))
    found["Rig/B"] = (rig.pose.bones["B"], targets.Target(rig, "B"))
    return found


@pytest.fixture
def loops(scene):
    scene.render.fps = FPS
    return loop_scene()


def played(owner, frames):
    """Blender's rotation of `owner` (object or pose bone) at `frames` (subframes too), (N, 4)."""
    target = targets.Target(owner.id_data, owner.name if owner.id_data != owner else None)
    return targets.playback(target).quats(np.asarray(frames, dtype=np.float64))


def closed_curve(target, method):
    """The method's closed curve through the target's keys (read before anything is written)."""
    keys = targets.read_rotation_keys(target)
    return native.require().Curve.from_channels(keys.frames, keys.values, keys.mode, method, cyclic=True)


def three_periods(loop, per_frame=4):
    """Frames from three periods before the keys to three after, every 1/per_frame frame."""
    return np.arange(loop.start - 3 * loop.period, loop.end + 3 * loop.period + 1e-9, 1.0 / per_frame)


def fresh_played(loops, frames, tmp_path):
    """{name: Blender's rotation of that loop's owner at frames[name]}, read from the saved file in a
    fresh Blender without the add-on."""
    from test_fit import fresh_blender_quats
    blend = tmp_path / "played.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    times = np.unique(np.concatenate([np.asarray(f, dtype=np.float64) for f in frames.values()]))
    requests = [[name.partition("/")[0], name.partition("/")[2] or None] for name in frames]
    got = fresh_blender_quats(blend, requests, times, tmp_path)
    out = {}
    for name, f in frames.items():
        out[name] = got[name][np.searchsorted(times, np.asarray(f, dtype=np.float64))]
    return out


def loop_curves(owner, prop):
    return sorted(rotation_fcurves(owner, prop), key=lambda f: f.array_index)


# ---- bake --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["SLERP", "SPLINE_C2"])
def test_bake_writes_one_period_with_the_cycles_modifier_and_plays_the_closed_curve(loops, method, tmp_path):
    want = {}
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        frames = three_periods(loop, per_frame=1)  # baked LINEAR keys at every frame: compared there
        want[name] = (loop, frames, closed_curve(target, method).sample(frames))
    result = bake.bake([t for _, t in loops.values()], bake.BakeSettings(method=method))
    assert all("a loop (Cycles modifier): one period baked" in " ".join(t.notes) for t in result.targets)
    for name, (owner, target) in loops.items():
        loop, frames, curve = want[name]
        prop = "rotation_quaternion" if owner.rotation_mode == "QUATERNION" else "rotation_euler"
        curves = loop_curves(owner, prop)
        for c in curves:
            assert (c.keyframe_points[0].co[0], c.keyframe_points[-1].co[0]) == (loop.start, loop.end), name
            assert len(c.keyframe_points) == loop.period + 1, name
        offset = "REPEAT_OFFSET" if name == "Wheel" else "REPEAT"
        assert {(c.modifiers[0].mode_before, c.modifiers[0].mode_after) for c in curves} == {(offset, offset)}
        assert cycles.loop_of(target) == cycles.Loop(loop.start, loop.end, name == "Wheel")
    got = fresh_played(loops, {name: w[1] for name, w in want.items()}, tmp_path)
    for name, (loop, frames, curve) in want.items():
        error = np.degrees(angles_between(got[name], curve)).max()
        assert error < 1e-3, (name, error)


def test_wheel_baked_to_quaternions_repeats_and_keeps_turning(loops):
    owner, target = loops["Wheel"]
    loop = cycles.loop_of(target)
    frames = three_periods(loop, per_frame=1)
    curve = closed_curve(target, "SLERP").sample(frames)
    bake.bake([target], bake.BakeSettings(method="SLERP", rotation_mode="QUATERNION"))
    curves = loop_curves(owner, "rotation_quaternion")
    assert {(c.modifiers[0].mode_before, c.modifiers[0].mode_after) for c in curves} == {("REPEAT", "REPEAT")}
    assert np.degrees(angles_between(played(owner, frames), curve)).max() < 1e-3


def test_bake_with_tolerance_reduces_one_period_within_it_everywhere(loops, tmp_path):
    tolerance = 0.05
    want = {}
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        frames = three_periods(loop, per_frame=64)
        want[name] = (frames, closed_curve(target, "SQUAD").sample(frames))
    result = bake.bake([t for _, t in loops.values()], bake.BakeSettings(method="SQUAD", tolerance=tolerance))
    for t in result.targets:
        assert t.max_error_deg <= tolerance, t
    got = fresh_played(loops, {name: w[0] for name, w in want.items()}, tmp_path)
    for name, (frames, curve) in want.items():
        error = np.degrees(angles_between(got[name], curve)).max()
        assert error < tolerance + 1e-3, (name, error)


# ---- reduce ------------------------------------------------------------------------------------------

def test_reduce_keeps_the_period_and_modifier_and_its_bound_holds_across_the_seam(loops, tmp_path):
    found = [t for _, t in loops.values()]
    bake.bake(found, bake.BakeSettings(method="SPLINE_C2"))  # dense loops to reduce
    want = {}
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        frames = three_periods(loop, per_frame=64)
        want[name] = (loop, frames, played(owner, frames))
    tolerance = 0.1
    result = reduce.reduce(found, reduce.ReduceSettings(tolerance=tolerance))
    assert result.keys_after < result.keys_before, result.summary()
    for line, t in zip(result.lines(), result.targets):
        assert "over the loop's period" in line and "at every instant" in line, line
        assert t.proven, line
    for name, (owner, target) in loops.items():
        assert cycles.loop_of(target) == want[name][0], name
    got = fresh_played(loops, {name: w[1] for name, w in want.items()}, tmp_path)
    for name, (loop, frames, before) in want.items():
        error = np.degrees(angles_between(got[name], before)).max()
        assert error <= tolerance + 1e-4, (name, error)


# ---- refusals ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("task", ["bake", "reduce", "gltf"])
def test_a_modifier_that_is_no_loop_is_refused_naming_target_channel_and_modifier(loops, task, tmp_path):
    owner, target = loops["EulerLoop"]
    loop_curves(owner, "rotation_euler")[1].modifiers.new("NOISE")
    message = r"EulerLoop: rotation_euler\[1\] has F-curve modifiers after its Cycles modifier \(NOISE\)"
    with pytest.raises(targets.TargetError, match=message):
        if task == "bake":
            bake.bake([target], bake.BakeSettings())
        elif task == "reduce":
            reduce.reduce([target], reduce.ReduceSettings())
        else:
            gltf.export(bpy.context.scene, str(tmp_path / "out.glb"), gltf.ExportSettings(method="SLERP"))


# ---- glTF -------------------------------------------------------------------------------------------

def node_rotations(found, frames):
    """{name: [Blender's world rotation in glTF's frame]} at `frames` (frame_set)."""
    scene = bpy.context.scene
    out = {name: [] for name in found}
    for t in frames:
        whole = math.floor(t)
        scene.frame_set(int(whole), subframe=float(t - whole))
        for name, (owner, target) in found.items():
            obj = target.object
            m = obj.matrix_world @ owner.matrix if target.bone else obj.matrix_world
            out[name].append(gltf_world(m))
    return out


def test_gltf_writes_one_period_per_sampler_that_plays_through_the_seam_when_wrapped(loops, tmp_path):
    path = tmp_path / "loops.glb"
    tolerance = 0.1
    periods = {name: cycles.loop_of(t) for name, (_, t) in loops.items()}
    result = gltf.export(bpy.context.scene, str(path), gltf.ExportSettings(method="AUTO", tolerance=tolerance))
    assert all(s.rewritten for s in result.samplers), result.lines()
    glb_file = GltfFile(str(path))
    worst, keys = 0.0, 0
    for name, (owner, target) in loops.items():
        loop = periods[name]
        node = glb_file.node(target.bone or target.object.name)
        times, values, interpolation = glb_file.samplers[node]
        keys += len(times)
        assert interpolation == "LINEAR"
        np.testing.assert_allclose(times[[0, -1]], np.float32([loop.start / FPS, loop.end / FPS]), rtol=0, atol=1e-6)
        assert (values[0] == values[-1]).all(), name
        # Two periods of time from the loop's start, wrapped into the clip as a looping player does,
        # against Blender playing the loop (three.js, Unity: t0 + (t - t0) mod P).
        frames = loop.start + np.arange(0, 2 * loop.period + 1e-9, 0.2)
        want = node_rotations({name: (owner, target)}, frames)[name]
        parent = glb_file.parent.get(node)
        for frame, rotation in zip(frames, want):
            wrapped = loop.start + math.fmod(frame - loop.start, loop.period)
            up = glb_file.world(glb_file.doc["nodes"][parent]["name"], wrapped / FPS) if parent is not None \
                else Quaternion()
            if target.bone:  # a joint's axes differ from the bone's by a fixed rotation: taken at the start
                if frame == frames[0]:
                    fixed = (up.inverted() @ rotation).inverted() @ glb_file.local(node, wrapped / FPS)
                rotation = rotation @ fixed
            error = angle(glb_file.local(node, wrapped / FPS), up.inverted() @ rotation)
            worst = max(worst, error)
            assert error <= tolerance + 2e-3, (name, frame, error)
    print("\nglTF loops: %d rotation keys over %d samplers, max error %.4f° over two periods (tolerance %g°)"
          % (keys, len(loops), worst, tolerance))


# ---- trails -----------------------------------------------------------------------------------------

def test_trails_draw_one_period_of_blender_and_the_closed_curve(loops):
    from quatcurve_blender import trails
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        trail = trails.compute_local(target, method="SPLINE_C2", frame_range=(0, 200))
        assert trail.error is None or trail.error == "", (name, trail.error)
        assert (trail.frames[0], trail.frames[-1]) == (loop.start, loop.end), name
        want = closed_curve(target, "SPLINE_C2").sample(trail.frames)
        assert np.degrees(angles_between(trail.quats["SPLINE_C2"], want)).max() < 1e-9, name


# ---- the CLI ----------------------------------------------------------------------------------------

@pytest.mark.per_kind
@pytest.mark.parametrize("task", [["--method", "SQUAD"], ["--reduce", "--tolerance", "0.1"]])
def test_cli_bakes_and_reduces_loops_keeping_them_loops(loops, tmp_path, task):
    from test_cli import run_cli
    source, out = tmp_path / "loops.blend", tmp_path / "out.blend"
    periods = {name: cycles.loop_of(t) for name, (_, t) in loops.items()}
    bpy.ops.wm.save_as_mainfile(filepath=str(source))
    proc = run_cli(task + ["--output", out, source])
    assert proc.returncode == 0, proc.stderr
    bpy.ops.wm.open_mainfile(filepath=str(out), load_ui=False)
    for name, loop in periods.items():
        obj_name, _, bone = name.partition("/")
        target = targets.Target(bpy.data.objects[obj_name], bone or None)
        assert cycles.loop_of(target) == loop, (name, proc.stdout)


@pytest.mark.per_kind
def test_cli_gltf_writes_one_period(loops, tmp_path):
    from test_cli import run_cli
    source, out = tmp_path / "loops.blend", tmp_path / "loops.glb"
    bpy.ops.wm.save_as_mainfile(filepath=str(source))
    proc = run_cli(["--gltf", out, source])
    assert proc.returncode == 0, proc.stderr
    glb_file = GltfFile(str(out))
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        times, values, _ = glb_file.samplers[glb_file.node(target.bone or target.object.name)]
        np.testing.assert_allclose(times[[0, -1]], np.float32([loop.start / FPS, loop.end / FPS]), rtol=0, atol=1e-6)
        assert (values[0] == values[-1]).all(), name


@pytest.mark.per_kind
@pytest.mark.parametrize("task", [["--fit", "--method", "SQUAD", "--tolerance", "0.05"], ["--convert", "QUATERNION"],
                                  ["--convert", "ZXY"]])
def test_cli_fits_and_converts_loops_keeping_them_loops(loops, tmp_path, task):
    """--fit and --convert on the quaternion loop, the uneven Euler loop, the offset wheel and the rig's
    bones: every target stays a loop over the same period (its Cycles modifiers kept; a wheel
    converted to quaternions repeats: a quaternion loop has no offset)."""
    from test_cli import run_cli
    source, out = tmp_path / "loops.blend", tmp_path / "out.blend"
    periods = {name: cycles.loop_of(t) for name, (_, t) in loops.items()}
    bpy.ops.wm.save_as_mainfile(filepath=str(source))
    proc = run_cli(task + ["--output", out, source])
    assert proc.returncode == 0, proc.stderr
    bpy.ops.wm.open_mainfile(filepath=str(out), load_ui=False)
    for name, loop in periods.items():
        obj_name, _, bone = name.partition("/")
        target = targets.Target(bpy.data.objects[obj_name], bone or None)
        after = cycles.loop_of(target)
        assert after is not None and (after.start, after.end) == (loop.start, loop.end), (name, after, proc.stdout)


@pytest.mark.per_kind
def test_cli_gltf_with_an_explicit_method_writes_one_period(loops, tmp_path):
    """--gltf-curve SQUAD on loops: one period per sampler, the first and last keys equal."""
    from test_cli import run_cli
    source, out = tmp_path / "loops.blend", tmp_path / "loops.glb"
    bpy.ops.wm.save_as_mainfile(filepath=str(source))
    proc = run_cli(["--gltf", out, "--gltf-curve", "SQUAD", source])
    assert proc.returncode == 0, proc.stderr
    glb_file = GltfFile(str(out))
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        times, values, _ = glb_file.samplers[glb_file.node(target.bone or target.object.name)]
        np.testing.assert_allclose(times[[0, -1]], np.float32([loop.start / FPS, loop.end / FPS]), rtol=0, atol=1e-6)
        assert (values[0] == values[-1]).all(), name


# ---- axis-angle loops, an action's Cyclic Animation range ------------------------------------------------

def axis_angle_loop(name="AxisLoop", cyclic_range=True):
    """An axis-angle loop (a spin about a tilted axis and back), its action a Cyclic Animation over the
    loop's keys (manual frame range, use_cyclic)."""
    owner = add_empty(name, "AXIS_ANGLE")
    key(owner, "rotation_axis_angle", ((1, (0.2, 0.3, 1, 0.1)), (9, (1.3, 0.3, 1, 0.1)),
                                       (20, (0.6, 1, 0.2, 0.3)), (25, (0.2, 0.3, 1, 0.1))))
    make_cyclic(owner, "rotation_axis_angle")
    action = owner.animation_data.action
    if cyclic_range:
        action.use_frame_range, action.frame_start, action.frame_end = True, 1, 25
        action.use_cyclic = True
    return owner, targets.Target(owner)


@pytest.mark.parametrize("method", ["SLERP", "SQUAD"])
def test_axis_angle_loop_with_a_cyclic_range_fits_and_bakes_as_a_loop(scene, method):
    from quatcurve_blender import fit
    scene.render.fps = FPS
    fitted, target = axis_angle_loop("Fitted")
    loop = cycles.loop_of(target)
    assert loop == cycles.Loop(1.0, 25.0, False)
    frames = three_periods(loop)
    want = closed_curve(target, method).sample(frames)
    fit.fit([target], fit.FitSettings(method=method, tolerance=0.05))
    assert cycles.loop_of(target) == loop
    error = np.degrees(angles_between(played(fitted, frames), want)).max()
    assert error < 0.05, error
    baked, target = axis_angle_loop("Baked")
    whole = three_periods(loop, per_frame=1)  # baked LINEAR keys at every frame: compared there
    want = closed_curve(target, method).sample(whole)
    result = bake.bake([target], bake.BakeSettings(method=method))
    assert "one period baked" in " ".join(result.targets[0].notes)
    assert cycles.loop_of(target) is not None
    error = np.degrees(angles_between(played(baked, whole), want)).max()
    assert error < 1e-3, error


def test_a_cyclic_range_that_is_not_the_loop_is_refused(scene):
    from quatcurve_blender import fit
    owner, target = axis_angle_loop("Short")
    owner.animation_data.action.frame_end = 20
    with pytest.raises(fit.FitError, match="Cyclic Animation over frames 1–20"):
        fit.fit([target], fit.FitSettings(method="SQUAD"))


@pytest.mark.per_kind
@pytest.mark.parametrize("task", [["--method", "SQUAD"], ["--reduce", "--tolerance", "0.1"],
                                  ["--convert", "QUATERNION"]])
def test_batch_passes_loops_through_every_task(loops, tmp_path, task):
    """A batch run over a .blend of loops (bake, reduce, convert): the saved file keeps every target a
    loop over its period; --gltf writes one period per sampler."""
    from test_batch import read_results, run_batch
    source = tmp_path / "loops.blend"
    periods = {name: cycles.loop_of(t) for name, (_, t) in loops.items()}
    bpy.ops.wm.save_as_mainfile(filepath=str(source))
    out = tmp_path / "out"
    proc = run_batch(task + ["--jobs", "1", "--output", out, source])
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    records, _ = read_results(out)
    assert records["loops.blend"]["status"] == "done", records
    bpy.ops.wm.open_mainfile(filepath=str(out / "loops.blend"), load_ui=False)
    for name, loop in periods.items():
        obj_name, _, bone = name.partition("/")
        target = targets.Target(bpy.data.objects[obj_name], bone or None)
        after = cycles.loop_of(target)
        assert after is not None and (after.start, after.end) == (loop.start, loop.end), (name, after, proc.stdout)


@pytest.mark.per_kind
def test_batch_gltf_writes_one_period(loops, tmp_path):
    from test_batch import read_results, run_batch
    source = tmp_path / "loops.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(source))
    out = tmp_path / "gltf"
    proc = run_batch(["--gltf", tmp_path / "unused.glb", "--jobs", "1", "--output", out, source])
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    records, _ = read_results(out)
    assert records["loops.blend"]["status"] == "done", records
    glb_file = GltfFile(str(out / "loops.glb"))
    for name, (owner, target) in loops.items():
        loop = cycles.loop_of(target)
        times, values, _ = glb_file.samplers[glb_file.node(target.bone or target.object.name)]
        np.testing.assert_allclose(times[[0, -1]], np.float32([loop.start / FPS, loop.end / FPS]), rtol=0, atol=1e-6)
        assert (values[0] == values[-1]).all(), name
