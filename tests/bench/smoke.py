"""What every Python benchmark in tests/bench shares (support code, not a benchmark): its own
arguments, its smoke mode and its exit.

`--smoke` among a benchmark's arguments (after `--` under Blender's binary) runs the smallest size
once: every code path of the full run, no repeats, no time compared with a target. The exit status
is non-zero when the benchmarked code raises, so CTest's bench.smoke.* tests (docs/testing.md) catch
a benchmark that no longer runs. `--help` (or `-h`) prints the benchmark's own docstring (what it
measures, how to run it, its options) and exits without running it. Scripts run by Blender's binary
put this folder on sys.path first (its --python does not)."""

import os
import sys
import traceback


def script_args():
    """The script's own arguments: after `--` under Blender's binary (whose own options come first),
    else after the script's name (a Python, with or without the bpy module)."""
    argv = sys.argv
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    return argv[1:] if argv and argv[0].endswith(".py") else []


SMOKE = "--smoke" in script_args()
HELP = "--help" in script_args() or "-h" in script_args()


def run(main, *args):
    """Runs main(*args) and exits with its status: what it returns (None: 0), a SystemExit's code
    (a message: printed, status 1), or 1 with the traceback printed when it raises. The bpy module
    leaves through os._exit, since it can hang in its exit-time destructors (seen with 4.5).
    With --help: the benchmark's docstring, status 0, main not run."""
    try:
        if HELP:
            print((sys.modules[main.__module__].__doc__ or "").strip())
            code = 0
        else:
            code = main(*args)
    except SystemExit as stop:
        code = stop.code
    except BaseException:  # noqa: BLE001 — any failure of the benchmarked code fails the run
        traceback.print_exc()
        code = 1
    if isinstance(code, str):
        print(code, file=sys.stderr)
        code = 1
    code = int(code or 0)
    sys.stdout.flush()
    sys.stderr.flush()
    bpy = sys.modules.get("bpy")
    if bpy is not None and not bpy.app.binary_path:
        os._exit(code)
    sys.exit(code)
