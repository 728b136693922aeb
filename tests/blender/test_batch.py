"""`quatcurve batch` (addon/quatcurve_blender/batch.py), run as a subprocess under the same Blender as
the tests; its workers are that Blender too. A tiny library: two .blend shots with rotation keys, a
small BVH clip, a glTF and an FBX clip (Blender's importers), a corrupt file and a file without
rotation animation.

Covered: a local run on two workers (records checked against batch.schema.json, outputs opened,
inputs unchanged), resuming and --force, byte-identical records apart from timings, a worker killed
with SIGKILL from outside mid-run and a rerun, a Blender that crashes on one file, a kill between
the output's temporary file and its rename, a Slurm job array on a one-node cluster started here
(collected results equal the local run's; a rerun submits only the unfinished files), and bad arguments (exit status 2, checked in this
process: nothing is started for them)."""

import hashlib
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import bpy
import jsonschema
import pytest

import broken_files
from quatcurve_blender import batch, fcurves
from slurm_cluster import Cluster, Unavailable

ADDON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(batch.__file__)))
SCRIPT = os.path.join(ADDON_DIR, "quatcurve_blender", "batch.py")
SCHEMA = os.path.join(ADDON_DIR, "quatcurve_blender", "batch.schema.json")
IS_BINARY = bool(bpy.app.binary_path)  # '' in the bpy module

BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0.0 0.0 0.0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0.0 1.0 0.0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0.0 1.0 0.0
    }
  }
}
MOTION
Frames: 24
Frame Time: 0.041667
"""


def batch_command(args):
    if IS_BINARY:
        return [bpy.app.binary_path, "--background", "--factory-startup", "--python", SCRIPT, "--"] + list(args)
    return [sys.executable, "-m", "quatcurve_blender.batch"] + list(args)


def batch_env(**extra):
    env = dict(os.environ, PYTHONNOUSERSITE="1", **extra)
    if not IS_BINARY:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (ADDON_DIR, env.get("PYTHONPATH")) if p)
    return env


def run_batch(args, **env):
    return subprocess.run(batch_command([str(a) for a in args]), capture_output=True, env=batch_env(**env),
                          timeout=600, encoding="utf-8", errors="replace")


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def tree_digests(folder):
    return {os.path.relpath(os.path.join(here, name), folder): digest(os.path.join(here, name))
            for here, _, names in os.walk(folder) for name in names}


def schema_validator(name):
    with open(SCHEMA, encoding="utf-8") as f:
        schema = json.load(f)
    return jsonschema.Draft202012Validator(dict(schema, **{"$ref": "#/$defs/" + name}))


def schema_errors(data, name):
    return ["%s: %s" % ("/".join(str(p) for p in e.absolute_path) or "$", e.message)
            for e in schema_validator(name).iter_errors(data)]


def read_results(out):
    with open(os.path.join(out, "results.jsonl"), encoding="utf-8") as f:
        records = [json.loads(line) for line in f]
    for record in records:
        assert schema_errors(record, "record") == [], record
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    assert schema_errors(summary, "summary") == [], summary
    return {r["input"]: r for r in records}, summary


def without_timings(out):
    """results.jsonl with every record's timings ('seconds', 'phase_seconds') removed, as text."""
    with open(os.path.join(out, "results.jsonl"), encoding="utf-8") as f:
        return "".join(json.dumps({k: v for k, v in json.loads(line).items() if k not in ("seconds", "phase_seconds")},
                                  sort_keys=True) + "\n" for line in f)


def make_shot(path, name, degrees):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(obj)
    obj.rotation_mode = "XYZ"
    for frame, angle in zip(range(1, 1 + 10 * len(degrees), 10), degrees):
        obj.rotation_euler = (math.radians(angle), math.radians(angle / 2), 0.0)
        obj.keyframe_insert("rotation_euler", frame=frame)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)


def make_library(root):
    """lib/shots/a.blend, lib/shots/b.blend, lib/shots/still.blend (no animation), lib/shots/bad.blend
    (not a .blend), lib/clips/walk.bvh (24 frames, 2 joints), lib/clips/spin.glb and lib/clips/roll.fbx
    (an animated empty through Blender's glTF and FBX exporters)."""
    shots, clips = root / "shots", root / "clips"
    shots.mkdir(parents=True)
    clips.mkdir()
    make_shot(shots / "a.blend", "A", (0, 90, 30, 120))
    make_shot(shots / "b.blend", "B", (10, -40, 80))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Still", None))
    bpy.ops.wm.save_as_mainfile(filepath=str(shots / "still.blend"), copy=True)
    (shots / "bad.blend").write_bytes(b"BLENDER-v300 this is not a blend file\n" * 4)
    motion = "".join("0 0 0 %g %g %g %g %g %g\n" % (3 * i, 40 * math.sin(i / 4), i, 0, 2 * i, 30 * math.cos(i / 5))
                     for i in range(24))
    (clips / "walk.bvh").write_text(BVH + motion)
    make_shot(shots / "spin.blend", "Spin", (0, 90, 30))  # exported, then removed: the glTF and FBX clips
    bpy.ops.export_scene.gltf(filepath=str(clips / "spin.glb"), export_format="GLB")
    bpy.ops.export_scene.fbx(filepath=str(clips / "roll.fbx"), bake_anim=True)
    (shots / "spin.blend").unlink()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return root


EXPECTED = {"clips/roll.fbx": "done", "clips/spin.glb": "done", "clips/walk.bvh": "done", "shots/a.blend": "done", "shots/b.blend": "done",
            "shots/bad.blend": "failed", "shots/still.blend": "failed"}


@pytest.fixture(scope="module")
def library(addon, tmp_path_factory):
    return make_library(tmp_path_factory.mktemp("batch") / "lib")


@pytest.fixture(scope="module")
def first_run(library, tmp_path_factory):
    """One reduce run over the library on two workers; the inputs' digests before it."""
    out = tmp_path_factory.mktemp("batch-out") / "out"
    before = tree_digests(library)
    proc = run_batch(["--reduce", "--tolerance", "0.05", "--jobs", "2", "--output", out, library])
    return out, proc, before, without_timings(out)


# ---- tests ------------------------------------------------------------------------------------------

def test_local_run(first_run, library):
    out, proc, before, _ = first_run
    assert proc.returncode == 1, (proc.stdout, proc.stderr)  # two files failed
    assert tree_digests(library) == before  # inputs never written
    records, summary = read_results(out)
    assert {k: r["status"] for k, r in records.items()} == EXPECTED
    assert list(records) == sorted(records)
    assert re.match(r"cannot read it: Blender: .*shots/bad\.blend.*; likely cause: it is damaged at byte 12: not a "
                    r"block header", records["shots/bad.blend"]["reason"]), records["shots/bad.blend"]["reason"]
    assert "no object or pose bone with rotation animation" in records["shots/still.blend"]["reason"]
    for name, record in records.items():
        assert os.path.isfile(out / record["output"]) == (record["status"] == "done"), name
        if record["status"] == "done":
            assert record["options"] == {"reduce": True, "tolerance": 0.05}
            assert 0 <= record["max_error_deg"] <= 0.05 + 1e-6
            assert 0 < record["keys_after"] <= record["keys_before"]
    assert records["clips/walk.bvh"]["targets"] == ["walk/Hips", "walk/Spine"]
    assert summary["done"] == 5 and summary["failed"] == 2 and summary["files"] == 7
    assert summary["keys_before"] == sum(r["keys_before"] for r in records.values() if r["status"] == "done")
    # a progress line per file, the summary table
    progress = [line for line in proc.stdout.splitlines() if line.startswith("[")]
    assert len(progress) == 7, proc.stdout
    assert any(re.match(r"^\[\d/7\] shots/a\.blend: done, \d+ → \d+ keys, \d\.\d{3}°, \d+\.\d s", line)
               for line in progress), progress
    assert "files  done  skipped  failed" in proc.stdout
    assert "failed: shots/bad.blend: " in proc.stdout
    # the output plays reduced keys: the shot's object has its rotation in a new action
    bpy.ops.wm.open_mainfile(filepath=str(out / "shots" / "a.blend"), load_ui=False)
    obj = bpy.data.objects["A"]
    counts = [fcurves.key_count(f) for f in fcurves.Channels.of(obj).find_all("rotation_euler", 3) if f is not None]
    assert sum(counts) == records["shots/a.blend"]["keys_after"]
    bpy.ops.wm.read_factory_settings(use_empty=True)


@pytest.mark.per_kind
def test_unreadable_files_say_why(addon, tmp_path):
    """A BVH cut in a frame row, an FBX and a .glb cut in half (broken_files.py): each record's reason,
    progress line and summary line give the exception Blender's importer raised and the likely cause,
    never the 'Location:' of bpy.ops that passed it on."""
    made = broken_files.make(str(tmp_path / "lib"))
    out = tmp_path / "out"
    proc = run_batch(["--reduce", "--jobs", "1", "--output", out, made["bvh"], made["fbx"], made["glb"]])
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    records, summary = read_results(out)
    reasons = {name: r["reason"] for name, r in records.items() if r["status"] == "failed"}
    assert sorted(reasons) == ["roll.fbx", "spin.glb", "walk.bvh"] and summary["failed"] == 3, records
    assert reasons["walk.bvh"].startswith("cannot read it: Blender's BVH importer raised IndexError: list index "
                                          "out of range (io_anim_bvh/import_bvh.py:"), reasons["walk.bvh"]
    assert reasons["walk.bvh"].endswith(
        "likely cause: the file ends early at line %d: the MOTION section declares 24 frames, %d are present and "
        "the next is cut short (4 of 9 values)" % (broken_files.CUT_BVH_LINE, broken_files.CUT_BVH_ROWS))
    assert reasons["roll.fbx"].startswith("cannot read it: Blender's FBX importer: "), reasons["roll.fbx"]
    assert "; likely cause: the file ends early: node '" in reasons["roll.fbx"], reasons["roll.fbx"]
    assert reasons["spin.glb"].startswith("cannot read it: Blender's glTF importer: "), reasons["spin.glb"]
    assert "; likely cause: the file ends early: its header declares " in reasons["spin.glb"], reasons["spin.glb"]
    assert str(tmp_path) not in " ".join(reasons.values())  # paths as the records name them
    printed = [line for line in proc.stdout.splitlines() if "walk.bvh" in line]
    assert len(printed) == 2 and all("IndexError: list index out of range" in line for line in printed), printed
    assert "Location:" not in proc.stdout and "Location:" not in " ".join(reasons.values())


@pytest.mark.per_kind
def test_resume_force_and_deterministic(first_run, library, tmp_path):
    out, _, _, _ = first_run
    again = run_batch(["--reduce", "--tolerance", "0.05", "--jobs", "2", "--output", out, library])
    assert again.returncode == 1
    records, summary = read_results(out)
    assert {k: r["status"] for k, r in records.items()} == dict(EXPECTED, **{
        k: "skipped" for k, v in EXPECTED.items() if v == "done"})
    assert summary["skipped"] == 5 and summary["done"] == 0
    assert "2 to do, 5 skipped" in again.stdout
    # --force redoes everything and gives the first run's records, apart from timings
    forced = tmp_path / "forced"
    shutil.copytree(out, forced)
    assert run_batch(["--reduce", "--tolerance", "0.05", "--jobs", "1", "--force", "--output", forced,
                      library]).returncode == 1
    fresh = tmp_path / "fresh"
    assert run_batch(["--tolerance", "0.05", "--reduce", "--output", fresh, library]).returncode == 1
    assert without_timings(forced) == without_timings(fresh)
    assert {k: r["status"] for k, r in read_results(forced)[0].items()} == EXPECTED
    # other options: every file again
    other = run_batch(["--reduce", "--tolerance", "0.2", "--output", fresh, library / "shots" / "a.blend"])
    assert other.returncode == 0 and "1 to do, 0 skipped" in other.stdout, other.stdout


def children(pid):
    try:
        with open("/proc/%d/task/%d/children" % (pid, pid)) as f:
            return [int(p) for p in f.read().split()]
    except OSError:
        return []


@pytest.mark.per_kind
def test_killed_worker_then_rerun(library, tmp_path):
    """A worker killed with SIGKILL from outside while it works on a file (held there by the test hook
    QUATCURVE_BATCH_FAULT='hang:…', which marks when it is there): that file fails with the reason, the
    others are done by a new worker; the rerun does only that file. No half-written output."""
    out, mark = tmp_path / "out", tmp_path / "hanging"
    inputs = [library / "shots" / "a.blend", library / "shots" / "b.blend", library / "clips" / "walk.bvh"]
    proc = subprocess.Popen(batch_command(["--reduce", "--jobs", "1", "--output", str(out)] + [str(p) for p in inputs]),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, encoding="utf-8",
                            env=batch_env(QUATCURVE_BATCH_FAULT="hang:shots/a.blend",
                                          QUATCURVE_BATCH_FAULT_MARK=str(mark)))
    deadline = time.monotonic() + 300
    while not mark.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert mark.exists(), "the worker never reached shots/a.blend"
    victims = children(proc.pid)
    assert len(victims) == 1, victims
    os.kill(victims[0], signal.SIGKILL)
    stdout, stderr = proc.communicate(timeout=600)
    assert proc.returncode == 1, (stdout, stderr)
    records, _ = read_results(out)
    failed = [k for k, r in records.items() if r["status"] == "failed"]
    assert failed == ["shots/a.blend"], records
    assert "SIGKILL" in records[failed[0]]["reason"]
    assert not os.path.exists(out / records[failed[0]]["output"])
    assert [k for k, r in records.items() if r["status"] == "done"] == sorted(set(records) - set(failed))
    rerun = run_batch(["--reduce", "--jobs", "1", "--output", out] + inputs)
    assert rerun.returncode == 0, (rerun.stdout, rerun.stderr)
    assert "1 to do, 2 skipped" in rerun.stdout
    records, summary = read_results(out)
    assert records[failed[0]]["status"] == "done" and summary["failed"] == 0


@pytest.mark.per_kind
def test_crash_on_one_file_and_kill_during_save(library, tmp_path):
    """A Blender that dies on one file (QUATCURVE_BATCH_FAULT=crash:…) fails only that file, so does
    one that takes longer than --timeout; a kill
    between the temporary output and its rename leaves the output path absent (the temporary is
    removed by the next run, which completes the file)."""
    out = tmp_path / "out"
    shots = library / "shots"
    inputs = [shots / "a.blend", shots / "b.blend"]
    proc = run_batch(["--jobs", "1", "--output", out] + inputs, QUATCURVE_BATCH_FAULT="crash:a.blend")
    assert proc.returncode == 1, (proc.stdout, proc.stderr)
    records, _ = read_results(out)
    assert records["a.blend"]["status"] == "failed" and records["b.blend"]["status"] == "done"
    assert records["a.blend"]["reason"] == "the Blender process ended with SIGKILL while working on this file"

    proc = run_batch(["--jobs", "1", "--timeout", "2", "--output", out, shots / "a.blend"],
                     QUATCURVE_BATCH_FAULT="hang:a.blend")
    assert proc.returncode == 1
    records, _ = read_results(out)
    assert records["a.blend"]["reason"] == "took longer than --timeout 2 s: its Blender process was stopped"

    proc = run_batch(["--jobs", "1", "--output", out] + inputs, QUATCURVE_BATCH_FAULT="kill-in-save:a.blend")
    assert proc.returncode == 1
    assert not (out / "a.blend").exists()
    leftovers = [n for n in os.listdir(out) if batch.TEMPORARY.match(n)]
    assert len(leftovers) == 1, os.listdir(out)
    proc = run_batch(["--jobs", "1", "--output", out] + inputs)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    assert (out / "a.blend").is_file() and not [n for n in os.listdir(out) if batch.TEMPORARY.match(n)]
    records, _ = read_results(out)
    assert records["a.blend"]["status"] == "done" and records["b.blend"]["status"] == "skipped"


@pytest.fixture
def cluster(tmp_path_factory):
    """A one-node Slurm cluster for one test (slurm_cluster.py); skipped with the reason where it
    cannot start."""
    started = Cluster(tmp_path_factory.mktemp("slurm"))
    try:
        started.start()
    except Unavailable as why:
        started.stop()
        pytest.skip("no Slurm cluster here: %s" % why)
    yield started
    started.stop()


def submitted_job(proc):
    found = re.search(r"submitted Slurm job (\d+)", proc.stdout)
    assert found, (proc.stdout, proc.stderr)
    return found.group(1)


@pytest.mark.per_kind
def test_slurm_array(first_run, library, cluster, tmp_path):
    """The library through `--slurm` (4 array tasks of up to 2 files), `--collect`: the same records
    as the local run apart from timings. A rerun submits only the two failed files."""
    out = tmp_path / "out"
    args = ["--reduce", "--tolerance", "0.05", "--slurm", "--chunk", "2", "--sbatch=--time=00:10:00",
            "--output", out, library]
    proc = run_batch(args, SLURM_CONF=cluster.conf)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    assert "7 to do in 4 chunks of up to 2" in proc.stdout
    cluster.wait(submitted_job(proc))
    collected = run_batch(["--collect", out], SLURM_CONF=cluster.conf)
    assert collected.returncode == 1, (collected.stdout, collected.stderr)  # two files failed
    assert "files  done  skipped  failed" in collected.stdout
    assert without_timings(out) == first_run[3]
    records, summary = read_results(out)
    assert summary["missing"] == 0 and summary["done"] == 5

    again = run_batch(args, SLURM_CONF=cluster.conf)
    assert again.returncode == 0 and "2 to do in 1 chunk of up to 2, 5 skipped" in again.stdout, again.stdout
    cluster.wait(submitted_job(again))
    assert run_batch(["--collect", out], SLURM_CONF=cluster.conf).returncode == 1
    records, summary = read_results(out)
    assert summary["skipped"] == 5 and summary["failed"] == 2 and summary["missing"] == 0


@pytest.mark.per_kind
def test_plan_for_a_farm(library, tmp_path, capsys):
    """--plan (for Flamenco: farm/flamenco/quatcurve-batch.js) writes the chunked plan and the
    per-chunk script without running anything (in this process)."""
    out = tmp_path / "out"
    assert batch.main(["batch", "--plan", "--chunk", "2", "--reduce", "--output", str(out), str(library)]) == 0
    printed = capsys.readouterr().out
    plan_path = out / batch.STATE / "plan.json"
    assert "plan: %s" % plan_path in printed and "chunks: 4" in printed
    plan = batch.load_plan(plan_path)
    assert plan["chunks"] == [[0, 1], [2, 3], [4, 5], [6]]
    assert [f["input"] for f in plan["files"]] == sorted(EXPECTED)
    with open(out / batch.STATE / "slurm" / "chunk.sh") as f:
        assert '--run-chunk %s "$SLURM_ARRAY_TASK_ID"' % plan_path in f.read()
    assert not (out / "results.jsonl").exists()


@pytest.mark.parametrize("name,args,fragment", [
    ("no-input", ["--output", "{OUT}"], "no input"),
    ("no-output", ["{LIB}"], "no output"),
    ("missing-input", ["--output", "{OUT}", "{LIB}/nope"], "no such file or folder"),
    ("no-match", ["--output", "{OUT}", "{LIB}/*.fbx"], "matches no"),
    ("report", ["--report", "r.json", "--output", "{OUT}", "{LIB}"], "not a batch option"),
    ("fit-and-reduce", ["--fit", "--reduce", "--output", "{OUT}", "{LIB}"], "exclude each other"),
    ("fit-method", ["--fit", "--method", "EULER", "--output", "{OUT}", "{LIB}"], "cannot be fitted"),
    ("reduce-method", ["--reduce", "--method", "SQUAD", "--output", "{OUT}", "{LIB}"], "not an option of --reduce"),
    ("jobs", ["--jobs", "0", "--output", "{OUT}", "{LIB}"], "--jobs 0"),
    ("collect-nothing", ["--collect", "{OUT}"], "no batch plan"),
    ("same-output", ["--output", "{OUT}", "{TMP}/same"], "inputs spin.bvh and spin.fbx would both be saved as spin.blend"),
])
@pytest.mark.per_kind
def test_bad_arguments(library, tmp_path, capsys, name, args, fragment):
    """Checked by the coordinator before any worker starts: run in this process."""
    (tmp_path / "same").mkdir()
    for name in ("spin.bvh", "spin.fbx"):
        (tmp_path / "same" / name).write_bytes(b"")
    args = [a.replace("{OUT}", str(tmp_path / "out")).replace("{LIB}", str(library)).replace("{TMP}", str(tmp_path))
            for a in args]
    assert batch.main(["batch"] + args) == 2
    captured = capsys.readouterr()
    errors = [line for line in captured.err.splitlines() if line.startswith("quatcurve: error:")]
    assert len(errors) == 1 and fragment in errors[0], captured.err
    assert "Traceback" not in captured.err
    assert not (tmp_path / "out" / "results.jsonl").exists()


def test_convert_and_gltf_are_batch_operations(library, tmp_path):
    """Every CLI task runs in a batch: --convert MODE saves each .blend, --gltf writes each file's .glb
    (DIR/<input>.glb; the path given to --gltf is only checked)."""
    shots = [library / "shots" / "a.blend", library / "shots" / "b.blend"]
    out = tmp_path / "converted"
    proc = run_batch(["--convert", "QUATERNION", "--jobs", "1", "--output", out] + shots)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    records, summary = read_results(out)
    assert {k: (r["status"], r["output"], r["operation"]) for k, r in records.items()} == {
        "a.blend": ("done", "a.blend", "convert"), "b.blend": ("done", "b.blend", "convert")}
    assert all(r["max_error_deg"] <= 0.05 + 1e-6 for r in records.values())
    bpy.ops.wm.open_mainfile(filepath=str(out / "a.blend"), load_ui=False)
    assert bpy.data.objects["A"].rotation_mode == "QUATERNION"
    bpy.ops.wm.read_factory_settings(use_empty=True)

    out = tmp_path / "gltf"
    proc = run_batch(["--gltf", tmp_path / "unused.glb", "--jobs", "1", "--output", out] + shots)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    records, _ = read_results(out)
    assert {k: (r["status"], r["output"]) for k, r in records.items()} == {
        "a.blend": ("done", "a.glb"), "b.blend": ("done", "b.glb")}
    assert (out / "a.glb").read_bytes()[:4] == b"glTF" and not (tmp_path / "unused.glb").exists()


def test_clean_records_its_figures(library, tmp_path):
    """--clean in a batch: each done file's record carries its clean figures (spike frames replaced,
    flips removed, the noise estimate), valid against the schema; max_error_deg is the largest deviation."""
    inputs = [library / "clips" / "walk.bvh", library / "shots" / "a.blend"]
    out = tmp_path / "cleaned"
    proc = run_batch(["--clean", "--jobs", "1", "--output", out] + inputs)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    records, _ = read_results(out)
    assert {k: (r["status"], r["operation"]) for k, r in records.items()} == {
        "clips/walk.bvh": ("done", "clean"), "shots/a.blend": ("done", "clean")}
    for record in records.values():
        figures = record["clean"]
        assert figures["spike_frames"] >= 0 and figures["flips"] >= 0 and figures["noise_deg"] >= 0, record
        assert record["max_error_deg"] <= 2.5 * figures["noise_deg"] + 1e-5, record
    assert records["shots/a.blend"]["clean"]["spike_frames"] == 0  # keyed straight segments: no spike


def test_clean_distance_records_the_bound(library, tmp_path):
    """--clean --error DISTANCE in a batch: the record's clean figures carry the bound and the shell
    (scene units), max_distance the worst virtual-vertex distance within it, max_error_deg null."""
    out = tmp_path / "cleaned"
    proc = run_batch(["--clean", "--error", "DISTANCE", "--distance", "0.5", "--jobs", "1", "--output", out,
                      library / "clips" / "walk.bvh", library / "shots" / "a.blend"])
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    records, _ = read_results(out)
    assert sorted(records) == ["clips/walk.bvh", "shots/a.blend"]
    for record in records.values():
        assert record["status"] == "done" and record["max_error_deg"] is None, record
        assert record["clean"]["distance"] == 0.5 and record["clean"]["shell"] > 0, record
        assert 0 <= record["max_distance"] <= 0.5, record
