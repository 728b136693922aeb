"""Blender's own playback of a saved .blend, in a Blender process that never loads the add-on
(sessions/evaluate_rotations.py): the checks' independent witness that what the add-on wrote plays
as it claims, with nothing of quatcurve in the loop.

Starting a Blender costs 1–2 s, and the suites ask for a playback a few dozen times each, so one
process per test session serves them all: it opens each file in turn (bpy.ops.wm.open_mainfile
replaces every datablock and the depsgraph) and is restarted after any failure, so one broken file
cannot leak into the next request."""
import json
import os
import subprocess
import sys
import threading

import bpy

EVALUATE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "sessions", "evaluate_rotations.py")
DONE = "quatcurve-evaluate:"
TIMEOUT = 300  # seconds per file


class Evaluator:
    """One Blender (this pass's: the same executable, or this Python with its bpy) without the add-on."""

    def __init__(self):
        self.proc = None

    def command(self):
        if bpy.app.binary_path:
            return [bpy.app.binary_path, "--background", "--factory-startup", "--python", EVALUATE, "--", "--serve"]
        return [sys.executable, EVALUATE, "--serve"]

    def start(self):
        self.proc = subprocess.Popen(self.command(), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, bufsize=1,
                                     env=dict(os.environ, PYTHONNOUSERSITE="1"))

    def stop(self):
        if self.proc is not None:
            if self.proc.poll() is None:
                self.proc.kill()
            self.proc.wait()
            self.proc = None

    def evaluate(self, blend, request_path, out_path):
        """Evaluates `blend` per the request file into out_path; raises AssertionError with the
        process's output when it fails (the process is then replaced by a new one)."""
        if self.proc is None or self.proc.poll() is not None:
            self.start()
        timer = threading.Timer(TIMEOUT, self.proc.kill)
        timer.start()
        log = []
        try:
            self.proc.stdin.write(json.dumps({"blend": str(blend), "request": str(request_path),
                                              "out": str(out_path)}) + "\n")
            self.proc.stdin.flush()
            status = None
            for line in self.proc.stdout:
                if line.startswith(DONE):
                    status = line[len(DONE):].strip()
                    break
                log.append(line)
        except OSError as error:
            status = "error %s" % error
        finally:
            timer.cancel()
        if status != "ok":
            ended = self.proc.poll()
            self.stop()
            raise AssertionError("Blender's evaluation of %s failed: %s\n%s" % (
                blend, status or "the process ended (exit %s)" % ended, "".join(log)[-3000:]))


_evaluator = Evaluator()


def evaluate(blend, request_path, out_path):
    _evaluator.evaluate(blend, request_path, out_path)


def stop():
    _evaluator.stop()
