"""The distance bound from the command line (issue 29): `cli.py --reduce --error DISTANCE` and
`batch.py --reduce --error DISTANCE` on the shared motion-capture clip (skipped when ../shared is
absent), at a unit scale of 0.01 (the clip is in centimetres: the defaults 1 mm / 10 cm are 0.1 /
10 scene units). The written .blend, posed by Blender itself in a fresh process, keeps every
virtual vertex within the distance of the input's pose at every frame and key; batch records the
worst distance per file (`max_distance`, scene units) and in its summary.

The helpers are test_reduce_distance.py's (posing, virtual vertices), the launches test_cli.py's
and test_batch.py's."""

import json
import os
import sys
from types import SimpleNamespace

import bpy
import pytest

from conftest import ROOT
from test_batch import read_results, run_batch
from test_cli import error_lines, run_cli
from test_fit import fresh_blender_quats
from test_reduce_distance import MOCAP, key_frames, worst_distance

DISTANCE, SHELL = 0.1, 10.0  # 1 mm and 10 cm at a unit scale of 0.01


def pose_of(blend, clip, tmp_path):
    """{bone: (N, 4, 4)} pose_bone.matrix at the clip's frames, Blender's own, from `blend`."""
    _, matrices = fresh_blender_quats(blend, [[clip.name, b.name] for b in clip.rig.data.bones], clip.frames,
                                      tmp_path, matrices=True)
    return {key.split("/", 1)[1]: m for key, m in matrices.items()}


@pytest.fixture(scope="module")
def clip(addon, tmp_path_factory):
    """The clip imported (BVH importer, quaternion bones) into mocap.blend; its frames, bones and
    Blender's pose of the input."""
    if not os.path.exists(MOCAP):
        pytest.skip("motion-capture clip %s not found (../shared/data/mocap/)" % MOCAP)
    sys.path.insert(0, os.path.join(ROOT, "build_scripts"))
    import demo_scene
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.unit_settings.scale_length = 0.01
    rig = demo_scene.import_bvh(MOCAP)
    folder = tmp_path_factory.mktemp("mocap")
    blend = folder / "in" / "mocap.blend"
    blend.parent.mkdir()
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    # Plain data: the rig itself goes with the next test's fresh file.
    bones = SimpleNamespace(bones=[SimpleNamespace(name=b.name, length=b.length) for b in rig.data.bones])
    found = SimpleNamespace(name=rig.name, blend=blend, frames=key_frames(rig),
                            rig=SimpleNamespace(name=rig.name, data=bones))
    found.before = pose_of(blend, found, folder)
    return found


def check_pose(clip, blend, tmp_path):
    after = pose_of(blend, clip, tmp_path)
    worst = worst_distance(clip.rig, clip.before, after, SHELL)
    print("%s: Blender's worst %.6g (bound %g) at %s frame %s" % (blend, worst[0], DISTANCE, worst[1],
                                                                 clip.frames[worst[2]]))
    assert worst[0] <= DISTANCE, worst
    return worst


def test_cli_reduce_distance_keeps_blenders_pose_within_the_default(clip, tmp_path):
    out = tmp_path / "reduced.blend"
    proc = run_cli(["--reduce", "--error", "DISTANCE", "--output", out, clip.blend])
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert any("reduce, distance 1 mm, shell 10 cm, BEZIER keys" in line for line in lines), proc.stdout
    total = next(line for line in lines if line.startswith("total: "))
    assert "worst distance" in total and "(bound 1 mm, shell 10 cm)" in total, total
    check_pose(clip, out, tmp_path)


@pytest.mark.per_kind
def test_cli_distance_options_are_refused_where_they_mean_nothing(clip, tmp_path):
    out = tmp_path / "out.blend"
    for args, words in ((["--reduce-keys", "LINEAR"], "--reduce-keys: not an option of a bake"),
                        (["--reduce", "--distance", "0.1"], "--distance, --shell: options of --error DISTANCE"),
                        (["--reduce", "--error", "DISTANCE", "--tolerance", "0.1"],
                         "--tolerance: not an option of --reduce --error DISTANCE"),
                        (["--reduce", "--error", "DISTANCE", "--distance", "-1"], "distance -1.0: must be a finite")):
        proc = run_cli(args + ["--output", out, clip.blend])
        assert proc.returncode == 2 and len(error_lines(proc)) == 1, proc.stderr
        assert words in error_lines(proc)[0], proc.stderr
        assert not out.exists()


@pytest.mark.per_kind
def test_batch_reduce_distance_records_the_worst_distance(clip, tmp_path):
    out = tmp_path / "out"
    proc = run_batch(["--reduce", "--error", "DISTANCE", "--distance", DISTANCE, "--shell", SHELL, "--jobs", "1",
                      "--output", out, clip.blend.parent])
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    records, summary = read_results(out)
    record = records["mocap.blend"]
    assert record["status"] == "done" and record["max_error_deg"] is None, record
    assert 0 < record["max_distance"] <= DISTANCE, record
    assert summary["max_distance"] == record["max_distance"] and summary["worst_input"] == "mocap.blend"
    assert record["keys_after"] < record["keys_before"]
    worst = check_pose(clip, out / "mocap.blend", tmp_path)
    # The record is the native verification of Blender's float32 evaluation; Blender's pose agrees.
    assert abs(worst[0] - record["max_distance"]) <= 0.05 * DISTANCE, (worst, record)
    print(json.dumps(record))


@pytest.mark.per_kind
def test_cli_and_batch_gltf_distance(clip, tmp_path):
    """--gltf --error DISTANCE: the export's distance bound from the command line and in a batch (the
    file itself is measured against Blender's pose in test_gltf_distance.py, through the same
    gltf.export)."""
    out = tmp_path / "mocap.glb"
    proc = run_cli(["--gltf", out, "--error", "DISTANCE", clip.blend])
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert any("glTF, curve AUTO, distance 1 mm, shell 10 cm" in line for line in lines), proc.stdout
    assert any(line.strip().startswith("%s: worst distance" % clip.name) for line in lines), proc.stdout
    total = next(line for line in lines if line.startswith("total: "))
    assert "worst distance" in total and "(bound 1 mm)" in total, total
    assert out.exists()
    refused = tmp_path / "refused.glb"
    proc = run_cli(["--gltf", refused, "--error", "DISTANCE", "--tolerance", "0.1", clip.blend])
    assert proc.returncode == 2 and "--tolerance: not an option of --gltf --error DISTANCE" in error_lines(proc)[0]
    assert not refused.exists()
    folder = tmp_path / "glb"
    proc = run_batch(["--gltf", tmp_path / "unused.glb", "--error", "DISTANCE", "--jobs", "1", "--output", folder,
                      clip.blend.parent])
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    records, summary = read_results(folder)
    record = records["mocap.blend"]
    assert record["status"] == "done" and record["max_error_deg"] is None, record
    assert 0 < record["max_distance"] <= DISTANCE, record
    assert summary["max_distance"] == record["max_distance"]
    assert (folder / "mocap.glb").exists()
