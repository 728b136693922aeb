"""The bake's reduction under the distance bound (issue 29), in every Blender the suite runs:
`quatcurve.bake(error='DISTANCE')` bakes dense, then reduces the baked action as
`quatcurve.reduce(error='DISTANCE')` does; the armature Blender itself poses from the saved result —
pose_bone.matrix in a fresh Blender without the add-on — keeps every virtual vertex (each bone's tail
and the points at `shell` along its axes) within `distance` of the dense bake's at every frame and
key. The same from the command line (`cli.py --error DISTANCE`). What the reduction would refuse is
refused before anything is written; a reduction refused after the dense keys are written (a
distance below the float32 floor) removes them again.

Motions: the shared motion-capture clip (Blender's BVH importer; skipped when ../shared is absent) at
a unit scale of 0.01 (1 mm real is 0.1 scene units), and the Rigify-like chain of rigs.py. The
helpers are test_reduce_distance.py's (posing, virtual vertices) and test_cli.py's (launches)."""

import os
import sys

import bpy
import pytest

from conftest import ROOT
from quatcurve_blender import bake, fcurves
from test_cli import error_lines, run_cli
from test_reduce_distance import MOCAP, key_frames, posed, worst_distance
import rigs

DISTANCE, SHELL = 0.1, 10.0  # 1 mm and 10 cm at a unit scale of 0.01


def import_clip():
    """The clip imported into the current (empty) scene at a unit scale of 0.01, every pose bone
    selected, in Pose mode."""
    if not os.path.exists(MOCAP):
        pytest.skip("motion-capture clip %s not found (../shared/data/mocap/)" % MOCAP)
    sys.path.insert(0, os.path.join(ROOT, "build_scripts"))
    import demo_scene
    bpy.context.scene.unit_settings.scale_length = 0.01
    rig = demo_scene.import_bvh(MOCAP)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="POSE")
    for pb in rig.pose.bones:
        if bpy.app.version >= (5, 0, 0):
            pb.select = True
        else:
            pb.bone.select = True
    return rig


def test_mocap_bake_keeps_every_virtual_vertex_within_the_distance_of_the_dense_bake(scene, tmp_path):
    rig = import_clip()
    original = fcurves.active_action(rig)
    # The reference: the same bake, dense (tolerance 0), posed by Blender.
    assert bpy.ops.quatcurve.bake(method="SQUAD", rotation_mode="QUATERNION", tolerance=0.0) == {"FINISHED"}
    dense_keys = bpy.context.scene.quatcurve.last_keys
    frames = key_frames(rig)
    dense = posed(rig, frames, tmp_path, "dense")
    fcurves.remove_action(fcurves.active_action(rig))
    fcurves.assign_action(rig, original)

    assert bpy.ops.quatcurve.bake(method="SQUAD", rotation_mode="QUATERNION", error="DISTANCE") == {"FINISHED"}
    settings = bpy.context.scene.quatcurve
    assert fcurves.active_action(rig).name == original.name + "_squad"
    assert settings.last_keys < dense_keys / 4, (settings.last_keys, dense_keys)
    assert "worst distance" in settings.last_summary and "(bound 1 mm, shell 10 cm)" in settings.last_summary
    assert any(line.startswith("reduced: %s: " % rig.name) and " frame " in line
               for line in settings.last_lines.splitlines()), settings.last_lines
    assert sorted(key_frames(rig)) == sorted(frames)  # the samples: the dense bake's every frame and key
    after = posed(rig, frames, tmp_path, "after")
    worst = worst_distance(rig, dense, after, SHELL)
    print("%s: %d -> %d keys, Blender's worst %.6g (bound %g) at %s frame %s; %s"
          % (rig.name, dense_keys, settings.last_keys, worst[0], DISTANCE, worst[1], frames[worst[2]],
             settings.last_summary))
    assert worst[0] <= DISTANCE, worst


@pytest.mark.per_kind
def test_cli_bake_with_error_distance(scene, tmp_path):
    import_clip()
    blend = tmp_path / "mocap.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    rig = bpy.context.view_layer.objects.active
    dense_out, out = tmp_path / "dense.blend", tmp_path / "reduced.blend"
    proc = run_cli(["--method", "SQUAD", "--output", dense_out, blend])
    assert proc.returncode == 0, proc.stderr[-3000:]
    proc = run_cli(["--method", "SQUAD", "--error", "DISTANCE", "--output", out, blend])
    assert proc.returncode == 0, proc.stderr[-3000:]
    total = next(line for line in proc.stdout.splitlines() if line.startswith("total: "))
    assert "worst distance" in total and "(bound 1 mm, shell 10 cm)" in total, total
    assert any(line.strip().startswith("reduced: %s: " % rig.name) for line in proc.stdout.splitlines()), proc.stdout
    frames = key_frames(rig)  # the input's every frame: the dense bake's keys
    dense = posed_file(rig, dense_out, frames, tmp_path)
    after = posed_file(rig, out, frames, tmp_path)
    worst = worst_distance(rig, dense, after, SHELL)
    print("cli: Blender's worst %.6g (bound %g) at %s frame %s; %s" % (worst[0], DISTANCE, worst[1],
                                                                      frames[worst[2]], total))
    assert worst[0] <= DISTANCE, worst
    for args, words in ((["--error", "DISTANCE", "--tolerance", "0.1"],
                         "--tolerance: not an option of a bake with --error DISTANCE"),
                        (["--error", "DISTANCE", "--no-new-action", "--in-place"], "turn New Action on"),
                        (["--distance", "0.1"], "--distance, --shell: options of --error DISTANCE")):
        bad = tmp_path / "bad.blend"
        proc = run_cli(args + ([] if "--in-place" in args else ["--output", bad]) + [blend])
        assert proc.returncode == 2 and len(error_lines(proc)) == 1, proc.stderr
        assert words in error_lines(proc)[0], proc.stderr
        assert not bad.exists()


def posed_file(rig, blend, frames, tmp_path):
    """{bone: (N, 4, 4)} pose_bone.matrix at `frames` in a fresh Blender from `blend`."""
    from test_fit import fresh_blender_quats
    _, matrices = fresh_blender_quats(blend, [[rig.name, b.name] for b in rig.data.bones], frames, tmp_path,
                                      matrices=True)
    return {key.split("/", 1)[1]: m for key, m in matrices.items()}


def test_refusals_write_nothing_and_a_late_refusal_removes_the_dense_bake(scene):
    rig = rigs.build_chain_rig()
    action = fcurves.active_action(rig)
    modes = {pb.name: pb.rotation_mode for pb in rig.pose.bones}
    constraint = rig.pose.bones["forearm.L"].constraints.new("COPY_ROTATION")
    constraint.name = "Follow"
    with pytest.raises(RuntimeError, match=r"Chain/forearm.L: constraint 'Follow'"):
        bpy.ops.quatcurve.bake(error="DISTANCE")
    constraint.mute = True
    with pytest.raises(RuntimeError, match=r"tolerance 0.1°: the distance bound is the reduction's bound"):
        bpy.ops.quatcurve.bake(error="DISTANCE", tolerance=0.1)
    with pytest.raises(RuntimeError, match=r"turn New Action on"):
        bpy.ops.quatcurve.bake(error="DISTANCE", new_action=False)
    # Below the float32 floor: refused by the reduction once the dense keys are written, which go again.
    with pytest.raises(bake.BakeError, match=r"distance bound: Chain: a distance of .* is below what Blender's "
                                             r"float32 posing keeps"):
        bake.bake([bake.targets.Target(rig, pb.name) for pb in rig.pose.bones],
                  bake.BakeSettings(rotation_mode="QUATERNION", error="DISTANCE", distance=1e-9))
    assert fcurves.active_action(rig) == action and not action.use_fake_user
    assert sorted(a.name for a in bpy.data.actions) == [action.name]
    assert {pb.name: pb.rotation_mode for pb in rig.pose.bones} == modes


def test_chain_rig_bake_in_every_rotation_mode_the_rig_keeps(scene, tmp_path):
    """The Rigify-like chain (its bones' own rotation modes, connected bones, an Inherit Rotation off
    head): Blender's pose of the reduced bake against its pose of the same bake dense, at every frame
    and key, within the distance — measured, not the result's own figure."""
    rig = rigs.build_chain_rig()
    original = fcurves.active_action(rig)
    every = [bake.targets.Target(rig, pb.name) for pb in rig.pose.bones]
    bake.bake(every, bake.BakeSettings(method="CATMULL_ROM", tolerance=0.0))
    frames = key_frames(rig)
    dense = posed(rig, frames, tmp_path, "dense")
    fcurves.remove_action(fcurves.active_action(rig))
    fcurves.assign_action(rig, original)

    result = bake.bake([bake.targets.Target(rig, pb.name) for pb in rig.pose.bones],
                       bake.BakeSettings(method="CATMULL_ROM", error="DISTANCE", distance=0.002, shell=0.1))
    assert result.reduction is not None and 0 < result.worst_distance <= 0.002
    assert result.keys_written == result.reduction.keys_after
    assert "worst distance" in result.summary()
    worst = worst_distance(rig, dense, posed(rig, frames, tmp_path, "after"), 0.1)
    print("chain rig: Blender's worst %.6g (bound 0.002) at %s frame %s; the bake reports %.6g"
          % (worst[0], worst[1], frames[worst[2]], result.worst_distance))
    assert worst[0] <= 0.002, worst
