"""farm/flamenco/quatcurve-batch.js, the Flamenco job type: `node` parses it, and its compileJob, run
in node against stand-ins for Flamenco's `author` and `path` (the documented job compiler API),
makes one task per chunk running `--run-chunk PLAN K` and a collect task after all of them. Not
tested against a Flamenco Manager (none can be installed here). Skips where node is missing."""

import json
import os
import shutil
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "farm", "flamenco", "quatcurve-batch.js")
NODE = shutil.which("node") or shutil.which("nodejs")

pytestmark = pytest.mark.skipif(NODE is None, reason="node is not installed (Debian package nodejs)")

# Flamenco's author/path objects, as far as the job type uses them; prints the tasks as JSON.
HARNESS = r"""
const fs = require("fs"), vm = require("vm"), posix = require("path").posix;
const tasks = [];
const sandbox = {
  path: { dirname: posix.dirname, basename: posix.basename, join: posix.join },
  print: () => {},
  author: {
    Task: (name, type) => { const t = { name, type, commands: [], deps: [] };
      t.addCommand = (c) => t.commands.push(c); t.addDependency = (d) => t.deps.push(d.name); return t; },
    Command: (type, parameters) => ({ type, parameters }),
  },
};
vm.createContext(sandbox);
vm.runInContext(fs.readFileSync(process.argv[1], "utf8") + "\n;globalThis.JOB_TYPE = JOB_TYPE;", sandbox);
const job = { settings: JSON.parse(process.argv[2]), addTask: (t) => tasks.push(t) };
try { sandbox.compileJob(job); } catch (e) { console.log(JSON.stringify({ error: String(e) })); process.exit(0); }
console.log(JSON.stringify({ jobType: sandbox.JOB_TYPE, tasks: tasks.map(({ name, type, commands, deps }) => ({ name, type, commands, deps })) }));
"""


def compile_job(settings):
    proc = subprocess.run([NODE, "-e", HARNESS, SCRIPT, json.dumps(settings)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_node_parses_it():
    proc = subprocess.run([NODE, "--check", SCRIPT], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr


def test_one_task_per_chunk_then_collect():
    settings = {"plan": "/farm/out/.quatcurve-batch/plan.json", "chunks": 3, "batch_script": "/farm/addon/batch.py",
                "blender_cmd": "{blender}", "blender_args": "{blenderArgs}"}
    result = compile_job(settings)
    keys = [s["key"] for s in result["jobType"]["settings"]]
    assert {"plan", "chunks", "batch_script"} <= set(keys)
    tasks = result["tasks"]
    assert [t["name"] for t in tasks] == ["quatcurve-chunk-0", "quatcurve-chunk-1", "quatcurve-chunk-2",
                                          "quatcurve-collect"]
    for k, task in enumerate(tasks[:3]):
        (command,) = task["commands"]
        assert command["type"] == "blender-render" and task["type"] == "blender"
        assert command["parameters"]["exe"] == "{blender}"
        assert command["parameters"]["args"] == ["--factory-startup", "--python", "/farm/addon/batch.py", "--",
                                                 "--run-chunk", settings["plan"], str(k)]
        assert task["deps"] == []
    collect = tasks[3]
    assert collect["commands"][0]["parameters"]["args"][-2:] == ["--collect", "/farm/out"]
    assert collect["deps"] == ["quatcurve-chunk-0", "quatcurve-chunk-1", "quatcurve-chunk-2"]


def test_bad_chunk_count_is_refused():
    result = compile_job({"plan": "/o/.quatcurve-batch/plan.json", "chunks": -1, "batch_script": "b.py",
                          "blender_cmd": "{blender}", "blender_args": ""})
    assert "chunks must be a whole number" in result["error"]
