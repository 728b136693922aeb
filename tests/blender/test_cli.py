"""The command line (addon/quatcurve_blender/cli.py), run as a subprocess under the same Blender as
the tests: the binary (`blender --background --python cli.py -- …`) or, for a bpy venv, its Python
(`python -m quatcurve_blender.cli …` with addon/ on PYTHONPATH).

Each launch costs about a second, so the cases are few: --help, a bake with --compare, an in-place
bake of chosen bones, a fit (--fit) and a fit that fails, and one launch per bad argument."""

import hashlib
import json
import math
import os
import shutil
import subprocess
import sys

import bpy
import numpy as np
import pytest
from mathutils import Quaternion

import broken_files
from compare_helpers import load_png, schema_errors
from quatcurve_blender import cli, compare, fcurves, fit, native, plot

ADDON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(cli.__file__)))
CLI = os.path.join(ADDON_DIR, "quatcurve_blender", "cli.py")
IS_BINARY = bool(bpy.app.binary_path)  # '' in the bpy module


def cli_command(args, preloaded=None):
    """The CLI under this test's Blender; `preloaded`: IN.blend given to the Blender binary itself
    (`blender -b IN.blend --python cli.py -- …`)."""
    if IS_BINARY:
        return ([bpy.app.binary_path, "--background", "--factory-startup"] + ([preloaded] if preloaded else [])
                + ["--python", CLI, "--"] + list(args))
    return [sys.executable, "-m", "quatcurve_blender.cli"] + list(args)


def run_cli(args, preloaded=None):
    env = dict(os.environ, PYTHONNOUSERSITE="1")
    if not IS_BINARY:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (ADDON_DIR, env.get("PYTHONPATH")) if p)
    proc = subprocess.run(cli_command([str(a) for a in args], preloaded), capture_output=True, env=env,
                          timeout=300, encoding="utf-8", errors="replace")
    return proc


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def error_lines(proc):
    return [line for line in proc.stderr.splitlines() if line.startswith("quatcurve: error:")]


def build_scene(path):
    """Turn: Euler XYZ keys (0°, 90°, 0°) → (90°, 45°, 90°), frames 1 → 21. Quat: 150° about Z, frames
    1 → 11. Still: no animation. Rig: pose bones B0 and B1 with quaternion keys, B2 without. LINEAR
    keys (the preference for new keys, restored afterwards)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    edit = bpy.context.preferences.edit
    previous = edit.keyframe_new_interpolation_type
    edit.keyframe_new_interpolation_type = "LINEAR"
    try:
        def empty(name, mode):
            obj = bpy.data.objects.new(name, None)
            scene.collection.objects.link(obj)
            obj.rotation_mode = mode
            return obj

        turn = empty("Turn", "XYZ")
        for frame, degrees in ((1, (0, 90, 0)), (21, (90, 45, 90))):
            turn.rotation_euler = [math.radians(d) for d in degrees]
            turn.keyframe_insert("rotation_euler", frame=frame)
        quat = empty("Quat", "QUATERNION")
        for frame, q in ((1, (1, 0, 0, 0)), (11, (math.cos(math.radians(75)), 0, 0, math.sin(math.radians(75))))):
            quat.rotation_quaternion = q
            quat.keyframe_insert("rotation_quaternion", frame=frame)
        empty("Still", "XYZ")

        rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
        scene.collection.objects.link(rig)
        bpy.context.view_layer.objects.active = rig
        bpy.ops.object.mode_set(mode="EDIT")
        for i, name in enumerate(("B0", "B1", "B2")):
            bone = rig.data.edit_bones.new(name)
            bone.head, bone.tail = (i, 0, 0), (i, 0, 1)
        bpy.ops.object.mode_set(mode="OBJECT")
        for name, axis in (("B0", (1, 0, 0)), ("B1", (0, 1, 0))):
            pb = rig.pose.bones[name]
            pb.rotation_mode = "QUATERNION"
            for frame, angle in ((1, 0.0), (11, 1.0), (21, 2.0)):
                pb.rotation_quaternion = Quaternion(axis, angle)
                pb.keyframe_insert("rotation_quaternion", frame=frame)
    finally:
        edit.keyframe_new_interpolation_type = previous
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)


@pytest.fixture(scope="module")
def source_blend(addon, tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "in.blend"
    build_scene(path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return path


def open_blend(path):
    bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)


def rotation_key_counts(rig, bone, count=4):
    channels = fcurves.Channels.of(rig)
    path = rig.pose.bones[bone].path_from_id("rotation_quaternion")
    return [fcurves.key_count(f) if f is not None else 0 for f in channels.find_all(path, count)]


# ---- tests ------------------------------------------------------------------------------------------

@pytest.mark.per_kind
def test_help_documents_every_option(addon):
    proc = run_cli(["--help"])
    assert proc.returncode == 0, proc.stderr
    options = [s for action in cli.build_parser()._actions for s in action.option_strings]
    assert len(options) >= 18
    missing = [o for o in options if o not in proc.stdout]
    assert not missing, "--help does not mention %s" % missing
    assert "exit status" in proc.stdout


def test_bake_with_compare_writes_file_report_and_plots(addon, source_blend, tmp_path):
    before = digest(source_blend)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    out, report = out_dir / "baked.blend", out_dir / "report.json"
    proc = run_cli(["--method", "SLERP", "--compare", "--report", report, "--output", out, source_blend])
    assert proc.returncode == 0, proc.stderr
    assert not error_lines(proc) and "Traceback" not in proc.stderr

    # Default selection: every object and pose bone with rotation animation (not Still, not Rig/B2).
    names = ["Quat", "Rig/B0", "Rig/B1", "Turn"]
    lines = proc.stdout.splitlines()
    for name in names:
        assert sum(line.strip().startswith(name + ": Slerp, ") for line in lines) == 1, proc.stdout  # the label
    assert any(line.startswith("total: 4 targets") for line in lines), proc.stdout
    assert any(": Slerp (SLERP), frames 1..21 step 1, in.blend → " in line for line in lines), proc.stdout

    assert digest(source_blend) == before
    assert sorted(os.listdir(out_dir)) == sorted(
        ["baked.blend", "report.json"] + [os.path.basename(compare.plot_path(str(report), n)) for n in names])

    data = json.loads(report.read_text(encoding="utf-8"))
    assert schema_errors(data) == []
    assert [t["name"] for t in data["targets"]] == names
    for target in data["targets"]:
        pixels = load_png(str(out_dir / target["plot"]))
        assert pixels.shape == (plot.HEIGHT, plot.WIDTH, 4)
        assert (np.abs(pixels[:, :, :3] * 255 - plot.INK) < 0.5).all(axis=2).any()  # axes and text in ink

    open_blend(out)
    scene = bpy.context.scene
    turn, quat = bpy.data.objects["Turn"], bpy.data.objects["Quat"]
    assert fcurves.active_action(turn).name.endswith("_slerp")
    assert bpy.data.actions[fcurves.active_action(turn).name[:-len("_slerp")]].use_fake_user
    scene.frame_set(11)  # the fixed-angle example's SLERP midpoint
    assert [round(math.degrees(a), 3) for a in turn.rotation_euler] == [90.0, 67.5, 90.0]
    scene.frame_set(6)
    angle = native.require().angle_between(tuple(quat.rotation_quaternion), (1.0, 0.0, 0.0, 0.0))
    assert math.degrees(angle) == pytest.approx(75.0, abs=1e-3)


def test_in_place_bakes_only_the_chosen_bones(addon, source_blend, tmp_path):
    path = tmp_path / "in_place.blend"
    shutil.copyfile(source_blend, path)
    before = digest(path)
    args = ["--in-place", "--objects", "R?g", "--bones", "B1", "--method", "SQUAD", "--rotation-mode", "QUATERNION"]
    # The binary is given IN.blend itself (the form `blender -b IN.blend --python cli.py -- …`).
    proc = run_cli(args, preloaded=str(path)) if IS_BINARY else run_cli(args + [path])
    assert proc.returncode == 0, proc.stderr
    assert [line.split(":")[0].strip() for line in proc.stdout.splitlines() if ": Squad, " in line] == ["Rig/B1"]
    assert digest(path) != before
    assert sorted(os.listdir(tmp_path)) == ["in_place.blend"]  # no temporary file, no .blend1

    open_blend(path)
    rig = bpy.data.objects["Rig"]
    assert fcurves.active_action(rig).name.endswith("_squad")
    assert rotation_key_counts(rig, "B1") == [21] * 4          # frames 1..21, every frame
    assert rotation_key_counts(rig, "B0") == [3] * 4           # untouched
    assert not fcurves.active_action(bpy.data.objects["Turn"]).name.endswith("_squad")


def fit_keys_of(owner):
    """Per rotation channel of the owner's mode: (frames, values, types) of every key."""
    prop, count = fcurves.rotation_property(owner.rotation_mode)
    channels = fcurves.Channels.of(owner.id_data)
    out = []
    for curve in channels.find_all(owner.path_from_id(prop), count):
        frames, values = fcurves.read_keys(curve)
        out.append((frames, values, fcurves.read_key_types(curve)))
    return out


def test_fit_keeps_the_animators_keys_and_plays_the_method(addon, source_blend, tmp_path):
    """--fit SQUAD on Quat and the rig's bones (Turn not chosen): the animator's keys stay, generated
    keys are marked, fit records are stored, and Blender plays SQUAD within the tolerance at every
    quarter frame; Turn and the input file are unchanged."""
    before = digest(source_blend)
    out = tmp_path / "fitted.blend"
    proc = run_cli(["--fit", "--method", "SQUAD", "--tolerance", "0.02", "--objects", "Quat,Rig", "--output", out,
                    source_blend])
    assert proc.returncode == 0, proc.stderr
    assert not error_lines(proc) and "Traceback" not in proc.stderr
    lines = proc.stdout.splitlines()
    assert any("fit Squad (SQUAD), tolerance 0.02°, 4 subframes" in line for line in lines), proc.stdout
    for name, count in (("Quat", 2), ("Rig/B0", 3), ("Rig/B1", 3)):
        assert any(line.strip().startswith("%s: QUATERNION, %d animator keys + " % (name, count)) for line in lines), \
            proc.stdout
    assert any(line.startswith("total: Fitted 3 targets with Squad (SQUAD): 8 animator + ") for line in lines), \
        proc.stdout
    assert digest(source_blend) == before

    open_blend(out)
    scene, qc = bpy.context.scene, native.require()
    turn = bpy.data.objects["Turn"]
    assert [len(f) for f, _, _ in fit_keys_of(turn)] == [2, 2, 2]  # not chosen: untouched
    times = np.arange(4, 21 * 4 + 1) / 4.0
    for owner, name in ((bpy.data.objects["Quat"], "Quat"), (bpy.data.objects["Rig"].pose.bones["B0"], "Rig/B0"),
                        (bpy.data.objects["Rig"].pose.bones["B1"], "Rig/B1")):
        keys = fit_keys_of(owner)
        mine = [(f[t != fit.KEY_TYPE_GENERATED], v[t != fit.KEY_TYPE_GENERATED]) for f, v, t in keys]
        frames = mine[0][0]
        assert all(np.array_equal(f, frames) for f, _ in mine), name
        values = np.stack([v for _, v in mine], axis=1).astype(np.float64)
        action = fcurves.active_action(owner.id_data)
        assert fit.find_record(action, fit.targets.Target(owner.id_data, owner.name if owner != owner.id_data
                                                              else None)).method == "SQUAD"
        want = qc.Curve(frames, values, "SQUAD").sample(times[times <= frames[-1]])
        got = []
        for t in times[times <= frames[-1]]:
            scene.frame_set(int(math.floor(t)), subframe=float(t - math.floor(t)))
            got.append(tuple(owner.rotation_quaternion.normalized()))
        err = np.degrees(qc.angle_between(np.array(got), want)).max()
        assert err <= 0.02 + 1e-3, "%s: %.5f°" % (name, err)


@pytest.mark.per_kind
def test_fit_that_fails_exits_1_and_saves_nothing(addon, tmp_path):
    """An axis-angle key with a zero axis cannot be fitted: status 1, one line naming the target,
    channels and frame, no output file."""
    source = tmp_path / "axis.blend"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = bpy.data.objects.new("Axis", None)
    bpy.context.scene.collection.objects.link(obj)
    obj.rotation_mode = "AXIS_ANGLE"
    for frame, angle in ((1, 0.0), (11, 2.0)):
        obj.rotation_axis_angle = (angle, 0, 0, 1 if frame == 1 else 0)
        obj.keyframe_insert("rotation_axis_angle", frame=frame)
    bpy.ops.wm.save_as_mainfile(filepath=str(source), copy=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    out = tmp_path / "out.blend"
    proc = run_cli(["--fit", "--output", out, source])
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    errors = error_lines(proc)
    assert len(errors) == 1 and "Axis: rotation_axis_angle[1..3] (the axis) is zero at frame 11" in errors[0], proc.stderr
    assert not out.exists()


def test_reduce(addon, source_blend, tmp_path):
    """--reduce on Turn: the reduce operator's work and summary, the input unchanged."""
    before = digest(source_blend)
    out = tmp_path / "reduced.blend"
    proc = run_cli(["--reduce", "--tolerance", "0.05", "--objects", "Turn", "--output", out, source_blend])
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert any("reduce, tolerance 0.05°, BEZIER keys" in line for line in lines), proc.stdout
    assert any(line.strip().startswith("Turn (XYZ): 6 → ") for line in lines), proc.stdout
    assert any(line.startswith("total: 1 target, rotation keys 6 → ") for line in lines), proc.stdout
    assert digest(source_blend) == before and out.is_file()


def test_clean(addon, source_blend, tmp_path):
    """--clean on Turn: the clean operator's work and summary (21 frames, no spikes on a keyed path),
    the input unchanged."""
    before = digest(source_blend)
    out = tmp_path / "cleaned.blend"
    proc = run_cli(["--clean", "--objects", "Turn", "--output", out, source_blend])
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert any("clean, deviation 2.5 × noise" in line for line in lines), proc.stdout
    assert any(line.strip().startswith("Turn (XYZ): 21 frames, noise ") and "no spikes" in line for line in lines), \
        proc.stdout
    assert any(line.startswith("total: 1 target: no spikes") for line in lines), proc.stdout
    assert digest(source_blend) == before and out.is_file()


def test_clean_distance(addon, source_blend, tmp_path):
    """--clean --error DISTANCE on Turn (an object: its three shell points, as --reduce does): the
    bound and shell in the header, the worst distance in the total, reduce's unit text."""
    out = tmp_path / "cleaned.blend"
    proc = run_cli(["--clean", "--error", "DISTANCE", "--distance", "0.002", "--shell", "0.1", "--objects", "Turn",
                    "--output", out, source_blend])
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert any("clean, distance 2 mm, shell 10 cm" in line for line in lines), proc.stdout
    assert any(line.strip().startswith("Turn (XYZ): 21 frames, noise ") and "virtual vertices within" in line
               for line in lines), proc.stdout
    assert any(line.startswith("total: 1 target: no spikes") and "(bound 2 mm, shell 10 cm; Turn, frame" in line
               for line in lines), proc.stdout


@pytest.fixture(scope="module")
def broken(addon, tmp_path_factory):
    return broken_files.make(str(tmp_path_factory.mktemp("broken")))


@pytest.mark.parametrize("kind,words", [
    ("bvh", ("Blender's BVH importer raised IndexError: list index out of range (io_anim_bvh/import_bvh.py:",
             "; likely cause: the file ends early at line %d: the MOTION section declares 24 frames, %d are present"
             % (broken_files.CUT_BVH_LINE, broken_files.CUT_BVH_ROWS))),
    ("fbx", ("Blender's FBX importer: ", "; likely cause: the file ends early: node '")),
    ("glb", ("Blender's glTF importer: ", "; likely cause: the file ends early: its header declares ")),
])
@pytest.mark.per_kind
def test_unreadable_input_says_why(broken, tmp_path, kind, words):
    """An input Blender's importer cannot read (broken_files.py): status 2, one line with the exception the
    importer raised and the likely cause; not bpy.ops' 'Location:', nor the traceback Blender prints for a
    failed operator (cli.output_held drops it); nothing saved."""
    out = tmp_path / "out.blend"
    proc = run_cli(["--reduce", "--output", out, broken[kind]])
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    errors = error_lines(proc)
    assert len(errors) == 1, proc.stderr
    assert errors[0].startswith("quatcurve: error: input %s: cannot read it: " % broken[kind]), errors[0]
    assert all(w in errors[0] for w in words), errors[0]
    printed = proc.stdout + proc.stderr
    assert "Location:" not in printed and "Traceback" not in printed and not out.exists(), printed


def test_imported_input(addon, tmp_path):
    """A .bvh is imported into an empty scene, as batch does, and reduced into OUT.blend; --in-place is
    refused (the input is not a .blend)."""
    clip = tmp_path / "walk.bvh"
    broken_files.write_bvh(str(clip))
    out = tmp_path / "walk.blend"
    proc = run_cli(["--reduce", "--output", out, clip])
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    assert any(line.startswith("total: 2 targets, rotation keys ") for line in proc.stdout.splitlines()), proc.stdout
    assert out.is_file()
    proc = run_cli(["--reduce", "--in-place", clip])
    assert proc.returncode == 2
    assert error_lines(proc) == ["quatcurve: error: --in-place: walk.bvh is imported, not a .blend: give --output "
                                 "OUT.blend"], proc.stderr


BAD_ARGUMENTS = [
    # (id, arguments with {IN} {OUT} {TMP}, exit status, words in the message)
    ("missing-input", ["--output", "{OUT}", "{TMP}/missing.blend"], 2, "no such file"),
    ("unknown-object", ["--objects", "Nope", "--output", "{OUT}", "{IN}"], 2, "no object matches"),
    ("unknown-bone", ["--bones", "Nope", "--output", "{OUT}", "{IN}"], 2, "no pose bone matches"),
    ("unknown-method", ["--method", "SLURP", "--output", "{OUT}", "{IN}"], 2, "invalid choice"),
    ("bad-range", ["--frame-range", "20", "10", "--output", "{OUT}", "{IN}"], 2, "is empty"),
    ("output-folder-missing", ["--output", "{TMP}/no/such/folder/out.blend", "{IN}"], 2, "does not exist"),
    ("output-is-input", ["--output", "{IN}", "{IN}"], 2, "--in-place"),
    # Not writable: refused up front for a normal user; root passes the access check, so Blender's
    # save fails (/proc takes no files) — a failure, status 1.
    ("fit-method", ["--fit", "--method", "EULER", "--output", "{OUT}", "{IN}"], 2, "cannot be fitted"),
    ("fit-tolerance", ["--fit", "--tolerance", "0", "--output", "{OUT}", "{IN}"], 2, "must be a finite angle above 0"),
    ("fit-bake-option", ["--fit", "--step", "2", "--rotation-mode", "XYZ", "--output", "{OUT}", "{IN}"], 2,
     "--rotation-mode, --step: not an option of --fit"),
    ("output-unwritable", ["--output", "/proc/quatcurve-cli-test.blend", "{IN}"], (1, 2), "writ"),
    ("fit-and-reduce", ["--fit", "--reduce", "--output", "{OUT}", "{IN}"], 2, "--fit and --reduce exclude each other"),
    ("reduce-method", ["--reduce", "--method", "SQUAD", "--output", "{OUT}", "{IN}"], 2,
     "--method: not an option of --reduce"),
    ("bake-reduce-option", ["--synchronized", "--output", "{OUT}", "{IN}"], 2, "--synchronized: not an option of a bake"),
    ("bake-clean-option", ["--deviation", "1", "--output", "{OUT}", "{IN}"], 2, "--deviation: not an option of a bake"),
    ("reduce-and-clean", ["--reduce", "--clean", "--output", "{OUT}", "{IN}"], 2, "--reduce and --clean exclude each other"),
    ("clean-reduce-option", ["--clean", "--synchronized", "--output", "{OUT}", "{IN}"], 2,
     "--synchronized: not an option of --clean"),
    ("clean-tolerance", ["--clean", "--tolerance", "0.1", "--output", "{OUT}", "{IN}"], 2,
     "--tolerance: an option of --clean only with --clean-reduce"),
    ("clean-deviation", ["--clean", "--deviation", "-1", "--output", "{OUT}", "{IN}"], 2, "deviation -1.0°"),
    ("clean-distance-deviation", ["--clean", "--error", "DISTANCE", "--deviation", "1", "--output", "{OUT}", "{IN}"],
     2, "--deviation: not an option of --clean --error DISTANCE"),
    ("clean-distance-angle", ["--clean", "--distance", "0.01", "--output", "{OUT}", "{IN}"], 2,
     "--distance, --shell: options of --error DISTANCE"),
    ("clean-distance-negative", ["--clean", "--error", "DISTANCE", "--distance", "-0.01", "--output", "{OUT}", "{IN}"],
     2, "distance -0.01: must be a finite length"),
    ("clean-distance-reduce", ["--clean", "--error", "DISTANCE", "--clean-reduce", "--output", "{OUT}", "{IN}"], 2,
     "reduce: its bound is an angle"),
]


@pytest.mark.per_kind
@pytest.mark.parametrize("case", BAD_ARGUMENTS, ids=[c[0] for c in BAD_ARGUMENTS])
def test_bad_argument_fails_with_one_line_and_leaves_input_alone(addon, source_blend, tmp_path, case):
    _, template, status, words = case
    out = tmp_path / "out.blend"
    args = [a.format(IN=source_blend, OUT=out, TMP=tmp_path) for a in template]
    before = digest(source_blend)
    proc = run_cli(args)
    expected = status if isinstance(status, tuple) else (status,)
    assert proc.returncode in expected, (proc.returncode, proc.stdout, proc.stderr)
    errors = error_lines(proc)
    assert len(errors) == 1, proc.stderr
    assert words in errors[0], errors[0]
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout
    assert digest(source_blend) == before
    assert not out.exists()
    assert not [n for n in os.listdir(source_blend.parent) if n.endswith(".tmp.blend")]
