"""Batch at library scale: a motion-capture library of --clips BVH clips (default 200) cut from the
shared clips (../shared/data/mocap: each clip a different source, start frame and length, and a yaw
offset on the root), reduced at 0.1° by `quatcurve batch --reduce`:
- with --jobs 1 and --jobs 2,
- many files per Blender process (the batch's workers) against one Blender process per file
  (--process-per-file: the cost a pipeline pays running cli.py once per file).
Prints clips per second and MB of input rotation channels per second (float32 values of the BVH
rotation channels: frames × rotation channels × 4 bytes), per run and per job, and the ratio to the
Animation Compression Library's published CMU figure: 2,534 clips, 1,429 MB in 1 min 55 s
(= 12.4 MB/s, on a desktop; ACL's MB also count translations and quaternion rotations, so ours is the
smaller measure for the same clip).

Every run is a fresh batch (--force) into its own output folder; the wall time is measured around
the whole command (planning, digests, workers, merge). The records of every run must be done and
equal apart from timings, or the benchmark stops.

Run with the Blender whose workers you want to measure:
  blender -b --factory-startup --python tests/bench/bench_batch.py -- [--clips 200] [--per-file-clips N]
  ~/.cache/quatcurve/bpy-5.0.1/bin/python tests/bench/bench_batch.py [--clips 200]
`--smoke` (tests/bench/smoke.py): the same four runs on 2 clips.
"""

import argparse
import json
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import smoke  # noqa: E402

ADDON_DIR = os.path.join(ROOT, "addon")
SCRIPT = os.path.join(ADDON_DIR, "quatcurve_blender", "batch.py")
MOCAP = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "mocap"))
ACL_MB, ACL_SECONDS, ACL_CLIPS = 1429.0, 115.0, 2534
TOLERANCE = "0.1"


def read_bvh(path):
    """(hierarchy text, channel names per column, motion rows as lists of strings)."""
    with open(path) as f:
        text = f.read()
    head, motion = text.split("MOTION", 1)
    lines = [line for line in motion.strip().splitlines() if line.strip()]
    rows = [line.split() for line in lines[2:]]  # after "Frames:" and "Frame Time:"
    channels = []
    for line in head.splitlines():
        words = line.split()
        if words and words[0] == "CHANNELS":
            channels += words[2:]
    frame_time = lines[1].split(":")[1].strip()
    return head, channels, rows, frame_time


def make_library(folder, count, seed=24):
    """`count` clips below folder/<source>/; returns (paths, MB of rotation channels)."""
    sources = sorted(f for f in os.listdir(MOCAP) if f.endswith(".bvh"))
    parsed = {name: read_bvh(os.path.join(MOCAP, name)) for name in sources}
    rng = random.Random(seed)
    paths, values = [], 0
    for i in range(count):
        name = sources[i % len(sources)]
        head, channels, rows, frame_time = parsed[name]
        length = rng.randint(min(60, len(rows)), len(rows))
        start = rng.randint(0, len(rows) - length)
        yaw = rng.uniform(-180, 180)
        yaw_column = next(c for c, n in enumerate(channels) if n.endswith("rotation"))  # the root's first angle
        clip = [list(row) for row in rows[start:start + length]]
        for row in clip:
            row[yaw_column] = "%.4f" % (float(row[yaw_column]) + yaw)
        out = os.path.join(folder, os.path.splitext(name)[0], "clip%03d.bvh" % i)
        os.makedirs(os.path.dirname(out), exist_ok=True)
        with open(out, "w") as f:
            f.write(head + "MOTION\nFrames: %d\nFrame Time: %s\n" % (length, frame_time))
            f.writelines(" ".join(row) + "\n" for row in clip)
        paths.append(out)
        values += length * sum(n.endswith("rotation") for n in channels)
    return paths, values * 4 / 1e6


def batch_command(args):
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "--background", "--factory-startup", "--python", SCRIPT, "--"] + args
    return [sys.executable, "-m", "quatcurve_blender.batch"] + args


def run(inputs, out, jobs, per_file):
    env = dict(os.environ, PYTHONNOUSERSITE="1")
    if not bpy.app.binary_path:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (ADDON_DIR, env.get("PYTHONPATH")) if p)
    args = ["--reduce", "--tolerance", TOLERANCE, "--force", "--jobs", str(jobs), "--output", out] + inputs
    if per_file:
        args.append("--process-per-file")
    begin = time.perf_counter()
    proc = subprocess.run(batch_command(args), capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - begin
    if proc.returncode != 0:
        sys.exit("batch failed (exit status %d):\n%s\n%s" % (proc.returncode, proc.stdout[-3000:], proc.stderr[-3000:]))
    with open(os.path.join(out, "results.jsonl")) as f:
        records = [json.loads(line) for line in f]
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return seconds, records, summary, proc.stdout


def without_timings(records):
    return [{k: v for k, v in r.items() if k not in ("seconds", "phase_seconds")} for r in records]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--clips", type=int, default=2 if smoke.SMOKE else 200)
    p.add_argument("--per-file-clips", type=int, default=None,
                   help="clips for the one-process-per-file runs (default: all)")
    p.add_argument("--keep", metavar="DIR", help="build the library and outputs here and keep them")
    p.add_argument("--smoke", action="store_true", help="the smallest run (tests/bench/smoke.py)")
    args = p.parse_args(smoke.script_args())
    if not os.path.isdir(MOCAP):
        print("skipped: %s is absent (the shared mocap clips)" % os.path.relpath(MOCAP, ROOT))
        return 0
    work = args.keep or tempfile.mkdtemp(prefix="quatcurve-bench-batch-")
    try:
        library = os.path.join(work, "library")
        paths, mb = make_library(library, args.clips)
        per_file_paths = paths[:args.per_file_clips] if args.per_file_clips else paths
        per_file_mb = sum(clip_mb(p) for p in per_file_paths)
        print("quatcurve batch benchmark (Blender %s, %d cores): %d clips from %s, %.1f MB of rotation channels "
              "(float32), reduce at %s°" % (bpy.app.version_string, os.cpu_count() or 1, len(paths),
                                            ", ".join(sorted(os.listdir(library))), mb, TOLERANCE), flush=True)
        rows, reference = [], None
        for per_file in (False, True):
            for jobs in (1, 2):
                inputs = per_file_paths if per_file else paths
                out = os.path.join(work, "out-%s-%d" % ("per-file" if per_file else "batch", jobs))
                seconds, records, summary, _ = run(inputs, out, jobs, per_file)
                if summary["done"] != len(inputs):
                    sys.exit("not every clip was done: %s" % json.dumps(summary)[:2000])
                same = {r["input"]: r for r in without_timings(records)}
                if reference is None:
                    reference = same
                differ = [(name, k, reference[name][k], r[k]) for name, r in same.items() for k in r
                          if r[k] != reference[name][k]]
                if differ:
                    sys.exit("runs disagree apart from timings: %s" % differ[:5])
                size = per_file_mb if per_file else mb
                rows.append(("one process per file" if per_file else "many files per process", jobs, len(inputs),
                             seconds, len(inputs) / seconds, size / seconds, size / seconds / jobs,
                             summary["keys_before"], summary["keys_after"], summary["max_error_deg"],
                             summary["timing"]["phase_seconds"]))
                print("  %s, --jobs %d: %d clips in %.1f s" % (rows[-1][0], jobs, len(inputs), seconds), flush=True)
        print()
        print("| processes | --jobs | clips | seconds | clips/s | MB/s | MB/s per job | per job ÷ ACL %.1f MB/s |"
              % (ACL_MB / ACL_SECONDS))
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        acl = ACL_MB / ACL_SECONDS
        for name, jobs, n, seconds, cps, mbs, per_job, *_ in rows:
            print("| %s | %d | %d | %.1f | %.2f | %.3f | %.3f | %.3f |" % (name, jobs, n, seconds, cps, mbs, per_job,
                                                                       per_job / acl))
        by = {(r[0], r[1]): r for r in rows}
        for jobs in (1, 2):
            batch_rate = by[("many files per process", jobs)][4]
            per_file_rate = by[("one process per file", jobs)][4]
            print("--jobs %d: many files per process %.2f clips/s = %.2f× one process per file (%.2f clips/s)"
                  % (jobs, batch_rate, batch_rate / per_file_rate, per_file_rate))
        first = rows[0]
        phases = first[10]
        print("many files per process, --jobs 1, where the work goes: loading (BVH import) %.1f s, reduce %.1f s, "
              "saving %.1f s" % (phases["load"], phases["task"], phases["save"]))
        print("rotation keys %s → %s, worst error %.4f° (bound %s°); ACL: %d clips, %s MB in %.0f s = %.1f MB/s"
              % (f"{first[7]:,}", f"{first[8]:,}", first[9], TOLERANCE, ACL_CLIPS, f"{ACL_MB:,.0f}", ACL_SECONDS, acl))
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


def clip_mb(path):
    _, channels, rows, _ = read_bvh(path)
    return len(rows) * sum(n.endswith("rotation") for n in channels) * 4 / 1e6


if __name__ == "__main__":
    smoke.run(main)
