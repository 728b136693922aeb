"""Batch: one operation of the command line on many files — a shot list or a motion-capture library —
in a few long-lived Blender processes, locally or as a Slurm job array.

    blender -b --python addon/quatcurve_blender/batch.py -- [options] --output DIR INPUT...
    PYTHONPATH=addon python -m quatcurve_blender.batch [options] --output DIR INPUT...   (a Python with bpy)

INPUT: files, folders (searched recursively) or glob patterns of .blend, .bvh, .fbx, .glb and .gltf
files (the last four through Blender's own importers). The operation and its options are the CLI's
(cli.add_task_arguments, cli.task_of): bake (default), --fit, --reduce, --convert MODE, --gltf, and
any task cli.TASKS gains. Each input gives DIR/<its path below the inputs' common folder, extension
.blend> (.glb for --gltf, whose own path argument is then only checked); inputs are never written. Per file one JSON line in DIR/results.jsonl and, at the end, DIR/summary.json (both
described by batch.schema.json); a summary table is printed.

How the work runs: the coordinator (this module's main) plans the files, then starts --jobs worker
processes — the same Blender (binary or bpy module) that runs it — and hands them one file at a time
over a pipe; a worker resets the scene (opening the .blend, or an empty factory scene for an
import), runs the task and saves the output atomically (cli.save_atomically: temporary file, then a
rename), and answers with the file's record. A worker that dies (a Blender crash, a kill, --timeout)
fails the file it was on, and a new worker takes the rest. The coordinator appends every record to
a part file as it arrives (DIR/.quatcurve-batch/parts/), so an interrupted run loses nothing done:
a rerun skips each file whose output exists and whose last record is done with the same input
digest and options (--force redoes it), and merges everything into results.jsonl in input order.

Slurm: --slurm writes the same plan and submits one array task per chunk of --chunk files; each
task runs `--run-chunk PLAN K` (the local machinery over its chunk, one worker), and
`--collect DIR` merges the parts into results.jsonl and summary.json. Rerunning --slurm submits
only the files without a finished record.

Exit status: 0 every file done or skipped; 1 some file failed (or, for --collect, is not finished);
2 bad arguments (one line on stderr, `quatcurve: error: <reason>`).
"""

import argparse
import glob
import hashlib
import json
import os
import queue
import re
import shlex
import signal
import subprocess
import sys
import threading
import time

if __package__:
    from . import cli, inputs, native, targets
    addon = sys.modules[__package__]
else:  # `blender --python batch.py`: a script outside its package (see cli.py)
    _here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != _here]
    sys.path.insert(0, os.path.dirname(_here))
    import quatcurve_blender as addon
    from quatcurve_blender import cli, inputs, native, targets

import bpy

PROG = "quatcurve_blender.batch"
EXIT_OK, EXIT_FAILURE, EXIT_USAGE = cli.EXIT_OK, cli.EXIT_FAILURE, cli.EXIT_USAGE
UsageError = cli.UsageError
EXTENSIONS = inputs.EXTENSIONS
STATE = ".quatcurve-batch"        # DIR's own folder: plan, part files, worker logs, Slurm script
RESULTS, SUMMARY = "results.jsonl", "summary.json"
ANSWER = b"quatcurve-batch-record "  # a worker's answer line (Blender prints its banner on the same pipe)
FORMAT = "quatcurve-batch"
VERSION = 1
# cli.save_atomically's temporary names: '.<name>.<12 hex>.tmp.blend' (a killed save leaves one)
TEMPORARY = re.compile(r"^\..+\.[0-9a-f]{12}\.tmp\.blend1?$")
# Test hook: QUATCURVE_BATCH_FAULT='crash:<input>' makes the worker kill itself (SIGKILL) when it
# starts that file, 'hang:<input>' wait there until it is stopped (first creating the file named by
# QUATCURVE_BATCH_FAULT_MARK, when set, so a test knows the worker is there), 'kill-in-save:<input>' kill
# itself after the output's temporary file is written but before its rename — a Blender that
# crashes on a file, one that never finishes it (--timeout), a machine that dies mid-save.
FAULT = "QUATCURVE_BATCH_FAULT"

USAGE_EPILOG = """\
exit status: 0 every file done or skipped, 1 some file failed, 2 bad arguments.

examples:
  blender -b --python addon/quatcurve_blender/batch.py -- --reduce --tolerance 0.1 --output out mocap/
  PYTHONPATH=addon python -m quatcurve_blender.batch --fit --method SQUAD --jobs 4 --output out 'shots/**/*.blend'
  blender -b --python addon/quatcurve_blender/batch.py -- --reduce --slurm --chunk 50 \\
      --sbatch=--partition=anim --sbatch=--time=02:00:00 --sbatch=--mem-per-cpu=4G --output /farm/out /farm/mocap
  blender -b --python addon/quatcurve_blender/batch.py -- --collect /farm/out
"""


def build_parser():
    """The batch parser: the CLI's task options (cli.add_task_arguments) and the batch's own.
    Returns (parser, the task options' destinations)."""
    p = cli.Parser(prog=PROG, formatter_class=argparse.RawDescriptionHelpFormatter, epilog=USAGE_EPILOG,
                   description="Run one quatcurve operation (bake, --fit, --reduce, ...: the options of "
                               "quatcurve_blender.cli) on many files,\nin --jobs Blender processes that each "
                               "handle many files, or as a Slurm job array.")
    p.add_argument("inputs", nargs="*", metavar="INPUT",
                   help="files, folders (searched recursively) or glob patterns ('shots/**/*.blend') of "
                        "%s files" % ", ".join(EXTENSIONS))
    task_options = cli.add_task_arguments(p)
    g = p.add_argument_group("batch")
    g.add_argument("--output", metavar="DIR", help="folder of the outputs (mirroring the inputs' tree), "
                                                   "results.jsonl and summary.json; created if missing")
    g.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="worker processes (default: the number of cores)")
    g.add_argument("--force", action="store_true", help="redo files already done with the same input and options")
    g.add_argument("--process-per-file", action="store_true",
                   help="a new Blender process for every file (slower: for comparison and for files that "
                        "leave state behind)")
    g.add_argument("--timeout", type=float, default=None, metavar="SECONDS",
                   help="a file taking longer fails and its worker is killed (default: no limit)")
    g = p.add_argument_group("slurm")
    g.add_argument("--slurm", action="store_true",
                   help="submit the work as a Slurm job array (sbatch --array) instead of running it here")
    g.add_argument("--chunk", type=int, default=20, metavar="FILES",
                   help="files per array task (default 20)")
    g.add_argument("--sbatch", action="append", default=[], metavar="ARG",
                   help="an argument for sbatch, repeatable: --sbatch=--partition=anim --sbatch=--time=2:00:00")
    g.add_argument("--plan", action="store_true",
                   help="only write the chunked plan for another farm manager (Flamenco) and print its path "
                        "and chunk count: each farm task runs --run-chunk PLAN K, then --collect DIR")
    g.add_argument("--collect", metavar="DIR",
                   help="merge the finished array tasks' records in DIR into results.jsonl and summary.json")
    p.add_argument("--worker", metavar="PLAN", help=argparse.SUPPRESS)
    p.add_argument("--run-chunk", nargs=2, metavar=("PLAN", "K"),
                   help="run chunk K of a plan written by --slurm or --plan (what each farm task runs)")
    return p, task_options


# ---- inputs ---------------------------------------------------------------------------------------

def _is_input(name):
    return name.lower().endswith(EXTENSIONS) and not name.startswith(".")


def _walk(folder, skip):
    found = []
    for here, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and os.path.join(here, d) not in skip)
        found += [os.path.join(here, f) for f in sorted(files) if _is_input(f)]
    return found


def expand_inputs(arguments, output_dir):
    """[(absolute path, path relative to the inputs' common folder)], sorted by the relative path.
    A folder brings its input files (recursively, hidden ones and the output folder skipped); a glob
    pattern its matches ('**' recursive). An argument that gives nothing is a UsageError."""
    skip = {os.path.abspath(output_dir)}
    files, bases = [], []
    for argument in arguments:
        path = os.path.abspath(argument)
        if glob.has_magic(argument):
            parts = path.split(os.sep)
            first = next(i for i, part in enumerate(parts) if glob.has_magic(part))
            bases.append(os.sep.join(parts[:first]) or os.sep)
            found = []
            for match in sorted(glob.glob(path, recursive=True)):
                if any(match == folder or match.startswith(folder + os.sep) for folder in skip):
                    continue  # the outputs of an earlier run
                if os.path.isdir(match):
                    found += _walk(match, skip)
                elif _is_input(os.path.basename(match)):
                    found.append(match)
            if not found:
                raise UsageError("input %s: matches no %s file" % (argument, "/".join(EXTENSIONS)))
            files += found
        elif os.path.isdir(path):
            found = _walk(path, skip)
            if not found:
                raise UsageError("input %s: a folder without %s files" % (argument, "/".join(EXTENSIONS)))
            bases.append(path)
            files += found
        elif os.path.isfile(path):
            if not path.lower().endswith(EXTENSIONS):
                raise UsageError("input %s: not a %s file" % (argument, "/".join(EXTENSIONS)))
            bases.append(os.path.dirname(path))
            files.append(path)
        else:
            raise UsageError("input %s: no such file or folder" % argument)
    root = os.path.commonpath(bases)
    unique = {}
    for path in files:
        unique.setdefault(os.path.realpath(path), path)
    return sorted(((path, os.path.relpath(path, root)) for path in unique.values()), key=lambda item: item[1])


def output_name(relative, suffix=".blend"):
    return os.path.splitext(relative)[0] + suffix


def file_digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return "sha256:" + h.hexdigest()


# ---- the plan: what every process of one run agrees on --------------------------------------------

def launcher():
    """The command that starts a worker (arguments follow), and its environment additions: the same
    Blender binary or the same Python with bpy as this process."""
    script = os.path.abspath(__file__)
    addon_parent = os.path.dirname(os.path.dirname(script))
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "--background", "--factory-startup", "--python", script, "--"], {}
    path = os.pathsep.join(p for p in (addon_parent, os.environ.get("PYTHONPATH")) if p)
    return [sys.executable, "-m", PROG], {"PYTHONPATH": path}


def make_plan(args, task_options, parser_defaults, argv):
    """Checks the arguments (UsageError) and returns the plan: the files with their digests and
    outputs, the task's arguments and options, the worker command."""
    if args.report is not None:
        raise UsageError("--report: not a batch option (each file's report is written beside its output)")
    if not args.output:
        raise UsageError("no output: give --output DIR")
    if not args.inputs:
        raise UsageError("no input: give files, folders or glob patterns")
    if args.jobs is not None and args.jobs < 1:
        raise UsageError("--jobs %d: must be 1 or more" % args.jobs)
    if args.chunk < 1:
        raise UsageError("--chunk %d: must be 1 or more" % args.chunk)
    if args.timeout is not None and not args.timeout > 0:
        raise UsageError("--timeout %g: must be above 0 seconds" % args.timeout)
    output = os.path.abspath(args.output)
    if os.path.exists(output) and not os.path.isdir(output):
        raise UsageError("--output %s: not a folder" % args.output)
    # The options given (not argparse's defaults): a record stays comparable when the CLI gains options.
    options = {name: getattr(args, name) for name in task_options if getattr(args, name) != parser_defaults[name]}
    task = cli.task_of(args)  # checks the task's settings now, before any process starts
    found = expand_inputs(args.inputs, output)
    by_output, files = {}, []
    for path, relative in found:
        out = output_name(relative, task.output_suffix)
        if out in by_output:
            raise UsageError("inputs %s and %s would both be saved as %s" % (by_output[out], relative, out))
        by_output[out] = relative
        if os.path.exists(os.path.join(output, out)) and os.path.samefile(os.path.join(output, out), path):
            raise UsageError("--output %s: would overwrite the input %s" % (args.output, relative))
        files.append({"path": path, "input": relative, "output": out})
    command, env = launcher()
    # The worker gets the task's own arguments again, parsed by the same parser.
    task_argv = [a for a in argv]
    return {"format": FORMAT + "-plan", "version": VERSION, "operation": task.verb, "options": options,
            "argv": task_argv, "output": output, "files": files, "launcher": command, "env": env,
            "timeout": args.timeout}


def state_dir(output, *parts):
    path = os.path.join(output, STATE, *parts)
    os.makedirs(path, exist_ok=True)
    return path


def write_json_atomically(path, text):
    temporary = "%s.%d.tmp" % (path, os.getpid())
    with open(temporary, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(temporary, path)


def save_plan(plan):
    path = os.path.join(state_dir(plan["output"]), "plan.json")
    write_json_atomically(path, json.dumps(plan, indent=1, sort_keys=True) + "\n")
    return path


def load_plan(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


# ---- records ---------------------------------------------------------------------------------------

def new_record(plan, entry, digest):
    return {"input": entry["input"], "output": entry["output"], "operation": plan["operation"],
            "options": plan["options"], "digest": digest, "status": "failed", "targets": [],
            "keys_before": 0, "keys_after": 0, "max_error_deg": None, "max_distance": None, "reason": None,
            "seconds": 0.0, "phase_seconds": {}}


def read_records(output):
    """input → the latest record: results.jsonl, then the part files in the order they were made."""
    latest = {}
    paths = [os.path.join(output, RESULTS)]
    parts = os.path.join(output, STATE, "parts")
    if os.path.isdir(parts):
        paths += [os.path.join(parts, name) for name in sorted(os.listdir(parts)) if name.endswith(".jsonl")]
    for path in paths:
        if not os.path.isfile(path):
            continue
        with open(path, encoding="utf-8") as f:
            for line in f:
                try:
                    record = json.loads(line)
                except ValueError:  # a line cut by a kill: that file is simply not recorded
                    continue
                if isinstance(record, dict) and "input" in record:
                    latest[record["input"]] = record
    return latest


def finished(record, plan, entry, digest):
    """True when `record` shows this file done with the same input and options, its output present."""
    return (record is not None and record.get("status") in ("done", "skipped") and record.get("digest") == digest
            and record.get("options") == plan["options"] and record.get("operation") == plan["operation"]
            and os.path.isfile(os.path.join(plan["output"], entry["output"])))


def sort_records(plan, latest):
    return [latest[entry["input"]] for entry in plan["files"] if entry["input"] in latest]


class PartFile:
    """Records appended as they arrive, each line flushed to disk: a kill loses no finished file."""

    def __init__(self, plan, name):
        self.path = os.path.join(state_dir(plan["output"], "parts"), "%s.jsonl" % name)
        self.file = open(self.path, "a", encoding="utf-8")

    def add(self, record):
        self.file.write(json.dumps(record, sort_keys=True, ensure_ascii=False) + "\n")
        self.file.flush()
        os.fsync(self.file.fileno())

    def close(self):
        self.file.close()


def run_name():
    return "%d-%d" % (time.time_ns(), os.getpid())


def pending_files(plan, force, part):
    """Indices of the files to do; records the others as skipped (their last record, status
    'skipped', seconds 0) in `part`. Returns (pending, skipped count)."""
    latest = {} if force else read_records(plan["output"])
    pending, skipped = [], 0
    for index, entry in enumerate(plan["files"]):
        digest = file_digest(entry["path"])
        entry["digest"] = digest
        record = latest.get(entry["input"])
        if not force and finished(record, plan, entry, digest):
            part.add(dict(record, status="skipped", seconds=0.0, phase_seconds={}))
            skipped += 1
        else:
            pending.append(index)
    return pending, skipped


# ---- the coordinator: workers, progress ------------------------------------------------------------

def default_jobs():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def _count(n):
    return f"{n:,}"


def _duration(seconds):
    seconds = int(round(seconds))
    if seconds < 60:
        return "%d s" % seconds
    if seconds < 3600:
        return "%d min %02d s" % divmod(seconds, 60)
    hours, rest = divmod(seconds, 3600)
    return "%d h %02d min" % (hours, rest // 60)


def progress_line(record):
    if record["status"] == "failed":
        return "%s: failed: %s" % (record["input"], record["reason"])
    error = "" if record["max_error_deg"] is None else ", %.3f°" % record["max_error_deg"]
    if record.get("max_distance") is not None:
        error += ", worst distance %.6g" % record["max_distance"]
    return "%s: %s, %s → %s keys%s, %.1f s" % (record["input"], record["status"], _count(record["keys_before"]),
                                              _count(record["keys_after"]), error, record["seconds"])


def signal_name(number):
    try:
        return signal.Signals(number).name
    except ValueError:
        return "signal %d" % number


class Worker:
    def __init__(self, plan, plan_path, log, threads):
        command, env = plan["launcher"], dict(os.environ, **plan["env"])
        env.setdefault("QUATCURVE_THREADS", str(threads))
        self.log = open(log, "ab")
        self.process = subprocess.Popen(command + ["--worker", plan_path], stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, stderr=self.log, env=env, bufsize=0)
        self.index = None
        self.started = None
        self.buffer = b""
        self.handled = 0
        self.timed_out = False

    def give(self, index):
        self.index, self.started = index, time.perf_counter()
        try:
            self.process.stdin.write(b"%d\n" % index)
            self.process.stdin.flush()
        except OSError:  # it has already ended: its end of output tells, and the file fails
            pass

    def close_input(self):
        try:
            self.process.stdin.close()
        except OSError:
            pass

    def end(self):
        self.close_input()
        code = self.process.wait()
        self.process.stdout.close()
        self.log.close()
        return code


def run_files(plan, plan_path, indices, jobs, part, process_per_file=False, out=sys.stdout, name="worker"):
    """Runs the files `indices` of the plan on `jobs` workers; each record goes to `part` and a
    progress line to `out`. Returns the records."""
    todo = list(indices)
    total, records, begin = len(todo), [], time.perf_counter()
    if not todo:
        return records
    jobs = max(1, min(jobs, total))
    threads = max(1, default_jobs() // jobs)
    logs = state_dir(plan["output"], "logs")
    # Each worker's output is read by a thread of its own into one queue: (worker, bytes), b"" when it ends.
    # (Waiting on the pipes together with `selectors` works on POSIX only: Windows' select() takes sockets.)
    output = queue.Queue()
    workers = []
    started = [0]

    def read(worker):
        fd = worker.process.stdout.fileno()
        while True:
            chunk = os.read(fd, 65536)
            output.put((worker, chunk))
            if not chunk:
                return

    def start():
        worker = Worker(plan, plan_path, os.path.join(logs, "%s-%d.log" % (name, started[0])), threads)
        started[0] += 1
        threading.Thread(target=read, args=(worker,), name="quatcurve-batch-read", daemon=True).start()
        workers.append(worker)
        feed(worker)

    def feed(worker):
        if todo and not (process_per_file and worker.handled):
            worker.give(todo.pop(0))
        else:
            worker.index = None
            worker.close_input()

    def report(record):
        part.add(record)
        records.append(record)
        elapsed = time.perf_counter() - begin
        left = total - len(records)
        eta = "" if not left else " · ETA %s" % _duration(elapsed / len(records) * left)
        print("[%d/%d] %s%s" % (len(records), total, progress_line(record), eta), file=out, flush=True)

    def crashed(worker, code):
        entry = plan["files"][worker.index]
        record = new_record(plan, entry, entry.get("digest"))
        if worker.timed_out:
            record["reason"] = "took longer than --timeout %g s: its Blender process was stopped" % plan["timeout"]
        elif code < 0:
            record["reason"] = "the Blender process ended with %s while working on this file" % signal_name(-code)
        else:
            record["reason"] = "the Blender process ended with exit status %d while working on this file%s" % (
                code, last_line(worker.log.name))
        record["seconds"] = round(time.perf_counter() - worker.started, 3)
        remove_output(plan, entry)
        report(record)

    for _ in range(jobs):
        start()
    while workers:
        try:
            worker, chunk = output.get(timeout=0.5)
        except queue.Empty:
            chunk = None
        if chunk:
            worker.buffer += chunk
            while b"\n" in worker.buffer:
                line, worker.buffer = worker.buffer.split(b"\n", 1)
                if not line.startswith(ANSWER):
                    continue
                record = json.loads(line[len(ANSWER):].decode("utf-8"))
                worker.index = None
                worker.handled += 1
                report(record)
                feed(worker)
        elif chunk is not None:  # the worker ended
            workers.remove(worker)
            code = worker.end()
            if worker.index is not None:
                crashed(worker, code)
            if todo:
                start()
        if plan.get("timeout"):
            now = time.perf_counter()
            for worker in workers:
                if worker.index is not None and not worker.timed_out and now - worker.started > plan["timeout"]:
                    worker.timed_out = True
                    worker.process.kill()
    return records


def last_line(log):
    """': <the last line of a worker's log>', or '' (a worker that ended by itself said why there)."""
    try:
        with open(log, "rb") as f:
            f.seek(max(0, os.path.getsize(log) - 4096))
            lines = [line.strip() for line in f.read().decode("utf-8", "replace").splitlines() if line.strip()]
    except OSError:
        return ""
    return ": " + lines[-1] if lines else ""


def remove_output(plan, entry):
    """A failed file leaves no output (an older one would contradict its record)."""
    path = os.path.join(plan["output"], entry["output"])
    if os.path.isfile(path):
        os.remove(path)


def remove_temporaries(output):
    """Temporary files of saves a kill interrupted (cli.save_atomically's names)."""
    for here, dirs, files in os.walk(output):
        dirs[:] = [d for d in dirs if d != STATE]
        for name in files:
            if TEMPORARY.match(name):
                os.remove(os.path.join(here, name))


# ---- results and summary ---------------------------------------------------------------------------

def summarize(plan, records, seconds=None, jobs=None):
    present = [r for r in records if r["status"] in ("done", "skipped")]
    errors = [(r["max_error_deg"], r["input"]) for r in present if r["max_error_deg"] is not None]
    worst = max(errors, key=lambda e: e[0]) if errors else (None, None)
    distances = [(r["max_distance"], r["input"]) for r in present if r.get("max_distance") is not None]
    farthest = max(distances, key=lambda e: e[0]) if distances else (None, None)
    if worst[1] is None:
        worst = (None, farthest[1])
    counts = {status: sum(r["status"] == status for r in records) for status in ("done", "skipped", "failed")}
    work = sum(r["seconds"] for r in records)
    phases = {phase: round(sum(r["phase_seconds"].get(phase, 0.0) for r in records), 3)
              for phase in ("load", "task", "save")}
    done_files = counts["done"] + counts["failed"]
    timing = {"seconds": None if seconds is None else round(seconds, 3), "work_seconds": round(work, 3),
              "phase_seconds": phases,
              "jobs": jobs,
              "files_per_second": round(done_files / seconds, 4) if seconds and done_files else None}
    return {"format": FORMAT + "-summary", "version": VERSION, "operation": plan["operation"],
            "options": plan["options"], "files": len(plan["files"]), "recorded": len(records),
            "done": counts["done"], "skipped": counts["skipped"], "failed": counts["failed"],
            "missing": len(plan["files"]) - len(records),
            "keys_before": sum(r["keys_before"] for r in present), "keys_after": sum(r["keys_after"] for r in present),
            "max_error_deg": worst[0], "max_distance": farthest[0], "worst_input": worst[1],
            "failures": [{"input": r["input"], "reason": r["reason"]} for r in records if r["status"] == "failed"],
            "timing": timing}


def summary_table(summary):
    t = summary["timing"]
    head = ("files", "done", "skipped", "failed", "keys before", "keys after", "worst error", "time", "files/s")
    row = (_count(summary["files"]), _count(summary["done"]), _count(summary["skipped"]), _count(summary["failed"]),
           _count(summary["keys_before"]), _count(summary["keys_after"]),
           "%.6g" % summary["max_distance"] if summary.get("max_distance") is not None else
           "-" if summary["max_error_deg"] is None else "%.4f°" % summary["max_error_deg"],
           "-" if t["seconds"] is None else "%.1f s" % t["seconds"],
           "-" if t["files_per_second"] is None else "%.2f" % t["files_per_second"])
    widths = [max(len(a), len(b)) for a, b in zip(head, row)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths)), "  ".join(c.rjust(w) for c, w in zip(row, widths))]
    phases = t["phase_seconds"]
    if any(phases.values()):
        lines.append("work: %.1f s (loading %.1f s, %s %.1f s, saving %.1f s)" % (
            t["work_seconds"], phases["load"], summary["operation"], phases["task"], phases["save"]))
    if summary["worst_input"]:
        lines.append("worst error: %s" % summary["worst_input"])
    if summary["missing"]:
        lines.append("not finished: %d file%s (rerun to do them)" % (summary["missing"], "" if summary["missing"] == 1 else "s"))
    for failure in summary["failures"]:
        lines.append("failed: %s: %s" % (failure["input"], failure["reason"]))
    return "\n".join(lines)


def merge(plan, seconds=None, jobs=None, out=sys.stdout, remove_parts=True):
    """results.jsonl (the latest record of every planned file, in input order) and summary.json,
    both written atomically; the part files merged are removed unless array tasks may still be
    writing them (--collect). Returns the summary."""
    output = plan["output"]
    records = sort_records(plan, read_records(output))
    text = "".join(json.dumps(r, sort_keys=True, ensure_ascii=False) + "\n" for r in records)
    write_json_atomically(os.path.join(output, RESULTS), text)
    summary = summarize(plan, records, seconds, jobs)
    write_json_atomically(os.path.join(output, SUMMARY), json.dumps(summary, indent=1, sort_keys=True) + "\n")
    parts = os.path.join(output, STATE, "parts")
    for name in os.listdir(parts) if remove_parts and os.path.isdir(parts) else ():
        os.remove(os.path.join(parts, name))
    print(summary_table(summary), file=out, flush=True)
    return summary


# ---- modes -----------------------------------------------------------------------------------------

def run_local(args, plan):
    jobs = args.jobs or default_jobs()
    remove_temporaries(plan["output"])
    begin = time.perf_counter()
    part = PartFile(plan, run_name())
    try:
        pending, skipped = pending_files(plan, args.force, part)
        plan_path = save_plan(plan)  # with the digests
        print("quatcurve batch (Blender %s): %s %d file%s, %d to do, %d skipped (done before with the same "
              "input and options), %d job%s%s" % (
                  bpy.app.version_string, plan["operation"], len(plan["files"]), "" if len(plan["files"]) == 1 else "s",
                  len(pending), skipped, jobs, "" if jobs == 1 else "s",
                  ", a process per file" if args.process_per_file else ""), flush=True)
        run_files(plan, plan_path, pending, jobs, part, args.process_per_file)
    finally:
        part.close()
    summary = merge(plan, time.perf_counter() - begin, jobs)
    return EXIT_FAILURE if summary["failed"] else EXIT_OK


def slurm_script(plan, plan_path):
    env = "".join("export %s=%s\n" % (k, shlex.quote(v)) for k, v in sorted(plan["env"].items()))
    return ("#!/bin/sh\n# quatcurve batch: one array task per chunk of files (written by %s)\n%s"
            "exec %s --run-chunk %s \"$SLURM_ARRAY_TASK_ID\"\n"
            % (PROG, env, " ".join(shlex.quote(a) for a in plan["launcher"]), shlex.quote(plan_path)))


def plan_chunks(args, plan):
    """Records the skipped files, splits the pending ones into chunks of --chunk files, saves the
    plan and the per-chunk script (DIR/.quatcurve-batch/slurm/chunk.sh, $SLURM_ARRAY_TASK_ID: the
    chunk). Returns (plan path, script path)."""
    part = PartFile(plan, run_name())
    try:
        pending, skipped = pending_files(plan, args.force, part)
    finally:
        part.close()
    remove_temporaries(plan["output"])
    plan["chunks"] = [pending[i:i + args.chunk] for i in range(0, len(pending), args.chunk)]
    plan["run"] = run_name()
    plan_path = save_plan(plan)
    folder = state_dir(plan["output"], "slurm")
    script = os.path.join(folder, "chunk.sh")
    with open(script, "w", encoding="utf-8") as f:
        f.write(slurm_script(plan, plan_path))
    os.chmod(script, 0o755)
    print("quatcurve batch: %s %d files, %d to do in %d chunk%s of up to %d, %d skipped" % (
        plan["operation"], len(plan["files"]), len(pending), len(plan["chunks"]),
        "" if len(plan["chunks"]) == 1 else "s", args.chunk, skipped), flush=True)
    return plan_path, script


def write_farm_plan(args, plan):
    """--plan: the chunked plan for another farm manager (Flamenco: farm/flamenco/quatcurve-batch.js),
    whose tasks run `--run-chunk PLAN K` for K in 0..chunks-1, then `--collect DIR`."""
    plan_path, _ = plan_chunks(args, plan)
    print("plan: %s" % plan_path)
    print("chunks: %d" % len(plan["chunks"]))
    if not plan["chunks"]:
        merge(plan, remove_parts=False)
    return EXIT_OK


def submit_slurm(args, plan):
    """Plans, records the skipped files, and submits the pending ones as an sbatch array."""
    plan_path, script = plan_chunks(args, plan)
    if not plan["chunks"]:
        merge(plan, remove_parts=False)
        return EXIT_OK
    folder = os.path.dirname(script)
    command = ["sbatch", "--parsable", "--array=0-%d" % (len(plan["chunks"]) - 1), "--job-name=quatcurve-batch",
               "--output=%s" % os.path.join(folder, "%A_%a.log")] + list(args.sbatch) + [script]
    try:
        proc = subprocess.run(command, capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as error:
        raise RuntimeError("sbatch could not run: %s" % error) from None
    if proc.returncode != 0:
        raise RuntimeError("sbatch failed: %s" % " ".join(proc.stderr.split()))
    job = proc.stdout.strip().split(";")[0]
    print("submitted Slurm job %s (array 0-%d); when it has finished: --collect %s"
          % (job, len(plan["chunks"]) - 1, plan["output"]), flush=True)
    return EXIT_OK


def run_chunk(plan_path, k):
    """One array task: the chunk's files, one worker at a time."""
    plan = load_plan(plan_path)
    chunk = plan["chunks"][int(k)]
    jobs = int(os.environ.get("SLURM_CPUS_PER_TASK", "1") or 1)
    part = PartFile(plan, "%s-chunk-%s" % (plan["run"], k))
    try:
        records = run_files(plan, plan_path, chunk, jobs, part, name="chunk-%s-worker" % k)
    finally:
        part.close()
    return EXIT_FAILURE if any(r["status"] == "failed" for r in records) else EXIT_OK


def collect(folder):
    path = os.path.join(os.path.abspath(folder), STATE, "plan.json")
    if not os.path.isfile(path):
        raise UsageError("--collect %s: no batch plan there (%s/plan.json)" % (folder, STATE))
    plan = load_plan(path)
    summary = merge(plan, remove_parts=False)
    return EXIT_FAILURE if summary["failed"] or summary["missing"] else EXIT_OK


# ---- the worker: many files, one after the other --------------------------------------------------

def load_input(path):
    """Resets the session to the file (inputs.read: a .blend opened, anything else imported into an
    empty factory scene). Raises RuntimeError: what the reader raised and the likely cause."""
    try:
        inputs.read(path)
    except inputs.InputError as error:
        raise RuntimeError("cannot read it: %s" % error) from None


def work_on(plan, task, args, index):
    """One file: load, choose the targets, the task, save. Returns its record."""
    entry = plan["files"][index]
    begin = time.perf_counter()
    record = new_record(plan, entry, entry.get("digest"))
    output = os.path.join(plan["output"], entry["output"])
    fault = os.environ.get(FAULT, "")
    phases = {}
    try:
        if fault == "crash:" + entry["input"]:
            os.kill(os.getpid(), signal.SIGKILL)
        if fault == "hang:" + entry["input"]:
            if os.environ.get(FAULT + "_MARK"):
                open(os.environ[FAULT + "_MARK"], "w").close()
            while True:
                time.sleep(1)
        load_input(entry["path"])
        phases["load"] = time.perf_counter() - begin
        scene = bpy.context.scene
        chosen = None
        if task.selects_targets:
            chosen = cli.select_targets(scene.objects, cli.split_patterns(args.objects), cli.split_patterns(args.bones))
        os.makedirs(os.path.dirname(output), exist_ok=True)
        task.check_output(output)
        result = task.apply(chosen, entry["path"], output)
        outcome = task.outcome(result)
        phases["task"] = time.perf_counter() - begin - phases["load"]
        if fault == "kill-in-save:" + entry["input"]:
            cli.os.replace = lambda *a: os.kill(os.getpid(), signal.SIGKILL)
        task.save(result, output)
        phases["save"] = time.perf_counter() - begin - phases["load"] - phases["task"]
        record.update(status="done", targets=outcome.targets, keys_before=outcome.keys_before,
                      keys_after=outcome.keys_after,
                      max_error_deg=None if outcome.max_error_deg is None else round(outcome.max_error_deg, 6),
                      max_distance=None if outcome.max_distance is None else float("%.9g" % outcome.max_distance))
        if outcome.clean is not None:
            record["clean"] = outcome.clean
    except (UsageError, targets.TargetError, RuntimeError, OSError, ValueError) as error:
        # Paths as the records name them: relative to the inputs' and the outputs' folders.
        reason = str(error).replace(entry["path"], entry["input"]).replace(output, entry["output"])
        # Blender's report prefix "Error: " goes, not an exception's type ("IndexError: …").
        record["reason"] = " ".join(re.sub(r"(?<!\w)Error: ", "", reason).split())
    except Exception as error:  # a bug: still the file's one-line reason
        record["reason"] = "internal error: %s: %s" % (type(error).__name__, " ".join(str(error).split()))
    if record["status"] == "failed":
        remove_output(plan, entry)
    record["seconds"] = round(time.perf_counter() - begin, 3)
    record["phase_seconds"] = {k: round(v, 3) for k, v in phases.items()}
    return record


def worker(plan_path):
    """Reads file indices from stdin, answers each with its record (one JSON line) on the original
    stdout; everything Blender and the task print goes to stderr (the worker's log)."""
    plan = load_plan(plan_path)
    answers = os.fdopen(os.dup(1), "wb")
    sys.stdout.flush()
    os.dup2(2, 1)
    args, _ = build_parser()[0].parse_known_args(plan["argv"])
    task = cli.task_of(args)
    native.require()
    registered = cli.register_addon()
    try:
        for line in sys.stdin:
            if not line.strip():
                continue
            record = work_on(plan, task, args, int(line))
            answers.write(ANSWER + json.dumps(record, sort_keys=True, ensure_ascii=False).encode("utf-8") + b"\n")
            answers.flush()
    finally:
        if registered:
            addon.unregister()
    return EXIT_OK


# ---- main ------------------------------------------------------------------------------------------

def main(argv=None):
    argv = cli.blender_args(sys.argv if argv is None else argv)
    parser, task_options = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as done:  # --help
        return int(done.code or 0)
    except UsageError as error:
        return cli.fail(EXIT_USAGE, "%s (see --help)" % error)
    try:
        if args.worker:
            return worker(args.worker)
        if args.run_chunk:
            return run_chunk(*args.run_chunk)
        if args.collect:
            return collect(args.collect)
        plan = make_plan(args, task_options, {name: parser.get_default(name) for name in task_options}, argv)
        os.makedirs(plan["output"], exist_ok=True)
        if args.slurm and args.plan:
            raise UsageError("--slurm and --plan exclude each other")
        if args.slurm:
            return submit_slurm(args, plan)
        if args.plan:
            return write_farm_plan(args, plan)
        return run_local(args, plan)
    except UsageError as error:
        return cli.fail(EXIT_USAGE, str(error))
    except (RuntimeError, OSError) as error:
        return cli.fail(EXIT_FAILURE, str(error))
    except KeyboardInterrupt:  # the finished files' records are on disk: a rerun goes on from there
        return cli.fail(EXIT_FAILURE, "interrupted: run the same command again to do the files not yet done")
    except Exception as error:
        if os.environ.get("QUATCURVE_DEBUG"):
            import traceback
            traceback.print_exc()
        return cli.fail(EXIT_FAILURE, "internal error: %s: %s" % (type(error).__name__, error))


if __name__ == "__main__":
    cli.exit_with(main())
