// quatcurve batch as a Flamenco 3 custom job type: one task per chunk of files, then one task that
// merges the records. Written from Flamenco's documented job compiler API (JOB_TYPE settings,
// compileJob(job), author.Task, author.Command("blender-render", ...), task.addDependency,
// job.addTask, path.dirname); untested against a Flamenco Manager (see docs/batch.md).
//
// Before submitting, plan the batch on the shared storage (same paths for the workers):
//
//   blender -b --python <addon>/quatcurve_blender/batch.py -- --plan --chunk 50 --reduce --output OUT INPUT...
//
// It prints the plan's path and the number of chunks: give them as the job's `plan` and `chunks`.
// Each chunk task runs the same command as a Slurm array task:
//
//   {blender} {blenderArgs} --factory-startup --python <batch.py> -- --run-chunk PLAN K
//
// and the last task `--collect OUT` writes OUT/results.jsonl and OUT/summary.json.
// Install: copy this file into the Manager's `scripts/` folder and restart the Manager.

const JOB_TYPE = {
    label: "quatcurve batch",
    description: "Fit, reduce or bake the rotation animation of many files with quatcurve, one task per chunk of files",
    settings: [
        { key: "plan", type: "string", subtype: "file_path", required: true,
          description: "plan.json written by `batch.py --plan` (OUT/.quatcurve-batch/plan.json)" },
        { key: "chunks", type: "int32", required: true,
          description: "Number of chunks, as `batch.py --plan` printed it" },
        { key: "batch_script", type: "string", subtype: "file_path", required: true,
          description: "quatcurve_blender/batch.py of the add-on, on the shared storage" },
        { key: "blender_cmd", type: "string", default: "{blender}", visible: "hidden" },
        { key: "blender_args", type: "string", default: "{blenderArgs}", visible: "hidden" },
    ],
};

function compileJob(job) {
    const settings = job.settings;
    const chunks = settings.chunks;
    if (!Number.isInteger(chunks) || chunks < 0) {
        throw `chunks must be a whole number of 0 or more, not ${chunks}`;
    }
    // The plan sits in OUT/.quatcurve-batch/plan.json.
    const output = path.dirname(path.dirname(settings.plan));

    const chunkTasks = [];
    for (let k = 0; k < chunks; k++) {
        const task = author.Task(`quatcurve-chunk-${k}`, "blender");
        task.addCommand(batchCommand(settings, ["--run-chunk", settings.plan, String(k)]));
        job.addTask(task);
        chunkTasks.push(task);
    }

    const collect = author.Task("quatcurve-collect", "blender");
    collect.addCommand(batchCommand(settings, ["--collect", output]));
    for (const task of chunkTasks) {
        collect.addDependency(task);
    }
    job.addTask(collect);
}

// The same Blender the Worker renders with, running batch.py in the background without a .blend.
function batchCommand(settings, batchArgs) {
    return author.Command("blender-render", {
        exe: settings.blender_cmd,
        exeArgs: settings.blender_args,
        argsBefore: [],
        blendfile: "",
        args: ["--factory-startup", "--python", settings.batch_script, "--"].concat(batchArgs),
    });
}
