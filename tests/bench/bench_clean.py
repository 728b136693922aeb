"""Cleaning captured rotations against Blender's own per-F-curve filters, on real motion capture with
noise of known size added (one run, prints a table per clip and noise level).

Each shared clip (../shared/data/mocap/*.bvh) is imported with Blender's BVH importer as quaternion
bones: its keys are the ground truth. A noisy copy of the action gets, by a fixed seed:
- rotation noise of NOISE_DEG RMS per bone and frame (isotropic: the angle off the truth),
- one spike of 10°–30° on a random bone every 200 frames,
- a quaternion sign flip every 50 frames (the stored signs of every bone flip, the rotations do not).
Then, each on its own copy of the noisy action, every method's result is played by Blender (its own
F-curve evaluation at every frame, normalized) and held against the truth:
- noisy: the input itself;
- quatcurve: clean.clean (the `quatcurve.clean` operator's function) with its defaults (deviation
  2.5 × the estimated noise);
- Blender's Gaussian Smooth (graph.gaussian_smooth, 4.0+), Butterworth (graph.butterworth_smooth, 4.2+)
  and classic Smooth (graph.smooth, repeated; the only one in 3.4), each on every rotation F-curve, at the setting of a scan
  that gives the lowest RMS error for that clip and noise (the best any user could pick).
Columns: the angle to the truth over every bone and frame (RMS, 99th percentile, max), the frames
further than 3 × the noise from the truth, jitter (the RMS of the angular acceleration, per frame²,
against the truth's own), and seconds. Goal (issue 36): quatcurve's RMS at most half the noisy
input's and below the best filter's, no frame beyond 3 × the noise.
A second table per clip and noise level: the distance at the virtual vertices (reduce's, with its
default 10 cm shell: each bone's tail and shell points in the armature's space, at a unit scale of
0.01 since the clips are in centimetres), RMS and max over bones and frames of each bone's farthest
vertex from the truth's, for the noisy input, the best Blender filter, quatcurve's clean and
quatcurve's clean with error='DISTANCE' at its default (the noise's reach; its bound and its worst
distance from the noisy input at the frames that are not spikes).

  ~/.cache/quatcurve/bpy-5.0.1/bin/python tests/bench/bench_clean.py
  blender -b --factory-startup --python tests/bench/bench_clean.py
`--picture PNG`: also draws, for the first clip at the last noise level, the bone with the largest
planted spike: its angular speed and its angle to the truth over time — the noisy input, the best
Blender filter and quatcurve (the add-on's own plotter, plot.py; README's picture).
`--smoke` (tests/bench/smoke.py): the first clip's first 120 frames, one noise level, two settings per filter.
"""
import math
import os
import sys
import tempfile
import time

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "addon"))
sys.path.insert(0, HERE)

import smoke  # noqa: E402
from bench_reduce_blender import first_frames, fresh_copy, graph_operator, import_clip, rotation_curves  # noqa: E402
from quatcurve_blender import clean, fcurves, native, plot, reduce, skeleton, targets  # noqa: E402

CLIPS = ("mocapbank.bvh", "freebvh.bvh")
MOCAP = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "mocap"))
NOISE_DEG = (0.5,) if smoke.SMOKE else (0.5, 2.0)
SMOKE_FRAMES = 120
SPIKE_EVERY, FLIP_EVERY = 200, 50
SCALE = 0.01  # scene unit scale: the clips are in centimetres (as bench_reduce_distance_blender)
if smoke.SMOKE:
    GAUSS = [(1.0, 4)]
    BUTTER = [(3.0, 4)]
    SMOOTH_PASSES = [1]
else:
    GAUSS = [(s, w) for s in (0.33, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0) for w in (4, 8, 12)]
    BUTTER = [(c, o) for c in (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0) for o in (2, 4)]
    SMOOTH_PASSES = [1, 2, 4, 8, 16]


def exp_map(r):
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    axis = np.divide(r, angle, out=np.zeros_like(r), where=angle > 0)
    return np.concatenate([np.cos(angle / 2), axis * np.sin(angle / 2)], axis=-1)


def qmul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def noisy_version(truth, noise_deg, seed):
    """{bone: (N, 4)} the truth with noise, spikes and sign flips (see the module docstring)."""
    rng = np.random.default_rng(seed)
    names = sorted(truth)
    n = len(next(iter(truth.values())))
    spikes = {}
    for start in range(0, n, SPIKE_EVERY):
        frame = int(rng.integers(start, min(n, start + SPIKE_EVERY)))
        spikes[(names[int(rng.integers(len(names)))], frame)] = math.radians(rng.uniform(10, 30))
    out = {}
    for name in names:
        r = rng.normal(scale=math.radians(noise_deg) / math.sqrt(3), size=(n, 3))
        for (bone, frame), angle in spikes.items():
            if bone == name:
                axis = rng.normal(size=3)
                r[frame] = axis / np.linalg.norm(axis) * angle
        q = qmul(truth[name], exp_map(r))
        q[(np.arange(n) // FLIP_EVERY) % 2 == 1] *= -1
        out[name] = q
    return out, spikes


def write_quats(arm, action, quats, frames):
    curves = rotation_curves(arm, action)
    for name, q in quats.items():
        for c, f in enumerate(curves[name]):
            fcurves.write_keys(f, frames, q[:, c], "LINEAR")


def played(arm, action, frames, names):
    curves = rotation_curves(arm, action)
    out = {}
    for name in names:
        q = np.stack([fcurves.evaluate(f, frames) for f in curves[name]], axis=1)
        out[name] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return out


def jitter(q):
    """RMS over the inner frames of the angular acceleration: the geodesic second difference, radians/frame²."""
    qc = native.require()
    mid = q[1:-1]
    ahead = q[2:] * np.where(np.sum(q[2:] * mid, 1) < 0, -1.0, 1.0)[:, None]
    behind = q[:-2] * np.where(np.sum(q[:-2] * mid, 1) < 0, -1.0, 1.0)[:, None]
    predicted = ahead + behind  # the geodesic midpoint, up to its length
    return qc.angle_between(mid, predicted / np.linalg.norm(predicted, axis=1, keepdims=True))


def figures(result, truth, noise_deg):
    qc = native.require()
    errors = np.concatenate([np.degrees(qc.angle_between(result[n], truth[n])) for n in truth])
    jit = np.sqrt(np.mean(np.concatenate([jitter(result[n]) ** 2 for n in truth])))
    return dict(rms=float(np.sqrt(np.mean(errors ** 2))), p99=float(np.percentile(errors, 99)),
                max=float(errors.max()), beyond=int((errors > 3 * noise_deg).sum()), jitter=math.degrees(jit))


def vertex_figures(read, played_by):
    """{name: (RMS, max)} in millimetres over bones and frames of each bone's farthest virtual vertex
    (Skeleton.vertex_distances, the default shell) from the truth's pose — read: the armature as
    skeleton.read_armature reads the truth; played_by {name: {bone: (N, 4)}}, bones not there kept
    as the truth."""
    qc = native.require()
    sk = read.skeleton()
    truth = np.array([qc.channels_to_quats(v, mode) for mode, v in read.rotations])
    shell = reduce.DEFAULT_SHELL / SCALE
    out = {}
    for name, quats in played_by.items():
        rotations = np.array([quats.get(bone, truth[b]) for b, bone in enumerate(read.names)])
        d = sk.vertex_distances((read.locations, truth, read.scales), (read.locations, rotations, read.scales), shell)
        mm = d * SCALE * 1000.0
        out[name] = (float(np.sqrt(np.mean(mm ** 2))), float(mm.max()))
    return out


def has_graph_operator(name):
    """Whether this Blender has bpy.ops.graph.<name> (bpy.ops answers any name until it is called)."""
    try:
        getattr(bpy.ops.graph, name).get_rna_type()
    except (KeyError, AttributeError):
        return False
    return True


def run_filter(arm, noisy_action, frames, names, operator, kwargs, passes=1):
    def run():
        for _ in range(passes):
            getattr(bpy.ops.graph, operator)(**kwargs)
    action, seconds = graph_operator(arm, noisy_action, "filtered", run)
    out = played(arm, action, frames, names)
    fcurves.remove_action(action)
    return out, seconds


def best_filter(label, arm, noisy_action, frames, truth, noise_deg, operator, settings, make_kwargs):
    """(label % the best setting, its figures, seconds, its played rotations {bone: (N, 4)})."""
    best = None
    for setting in settings:
        kwargs, passes = make_kwargs(setting)
        result, seconds = run_filter(arm, noisy_action, frames, sorted(truth), operator, kwargs, passes)
        fig = figures(result, truth, noise_deg)
        if best is None or fig["rms"] < best[1]["rms"]:
            best = (setting, fig, seconds, result)
    setting, fig, seconds, result = best
    return (label % setting, fig, seconds, result)


def draw_picture(path, clip, bone, frames, truth, noise_deg, played_by):
    """The PNG at `path`: `bone`'s angular speed and angle to the truth over time for each of
    played_by [(name, {bone: (N, 4)})] (plot.render_comparison, written by Blender's image save)."""
    qc = native.require()
    series = []
    for name, quats in played_by:
        q = quats[bone]
        series.append(dict(name=name, frames=frames, deviation=np.degrees(qc.angle_between(q, truth[bone])),
                           speed_frames=0.5 * (frames[1:] + frames[:-1]),
                           speed=np.degrees(qc.angle_between(q[1:], q[:-1]))))
    pixels = plot.render_comparison("%s, %s: %.1f° noise, spikes, sign flips" % (clip, bone, noise_deg), series,
                                    subtitle="angle to the truth before and after cleaning",
                                    titles=(("Angular speed", "speed (°/frame)"), ("Angle to the truth", "angle (°)")))
    image = bpy.data.images.new("bench_clean", pixels.shape[1], pixels.shape[0], alpha=True)
    image.pixels.foreach_set((pixels[::-1].astype(np.float32) / 255.0).ravel())
    image.filepath_raw = os.path.abspath(path)
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)
    print("wrote %s" % path)


def bench_clip(path, folder, picture=None):
    clip = first_frames(path, SMOKE_FRAMES, folder) if smoke.SMOKE else path
    arm, original = import_clip(clip)
    bpy.context.scene.unit_settings.scale_length = SCALE
    original.use_fake_user = True
    curves = rotation_curves(arm, original)
    frames = fcurves.key_frames(curves[next(iter(curves))])
    truth = {name: np.stack([fcurves.read_keys(f)[1] for f in fc], axis=1) for name, fc in curves.items()}
    truth = {name: q / np.linalg.norm(q, axis=1, keepdims=True) for name, q in truth.items()}
    truth_read = skeleton.read_armature(arm, [])
    assert np.array_equal(truth_read.frames, frames), "the skeleton's frames are not the keys'"
    print("\nBlender %s, %s: %d frames, %d bones" % (bpy.app.version_string, os.path.basename(path), len(frames),
                                                  len(truth)))
    for k, noise_deg in enumerate(NOISE_DEG):
        quats, spikes = noisy_version(truth, noise_deg, seed=17 + k)
        noisy_action = fresh_copy(arm, original, "noisy")
        noisy_action.use_fake_user = True
        write_quats(arm, noisy_action, quats, frames)
        noisy_played = played(arm, noisy_action, frames, sorted(truth))
        rows = [("noisy input", figures(noisy_played, truth, noise_deg), 0.0, noisy_played)]
        # quatcurve: the operator's function on every rotating bone, into a new action
        fcurves.assign_action(arm, noisy_action)
        begin = time.perf_counter()
        result = clean.clean([targets.Target(arm, name) for name in sorted(truth)], clean.CleanSettings())
        seconds = time.perf_counter() - begin
        cleaned = fcurves.active_action(arm)
        cleaned_played = played(arm, cleaned, frames, sorted(truth))
        rows.append(("quatcurve clean", figures(cleaned_played, truth, noise_deg), seconds, cleaned_played))
        # result.targets follow the targets given, one per bone in sorted(truth)
        found = {(name, int(round(f - frames[0]))) for name, t in zip(sorted(truth), result.targets) for f in t.spikes}
        planted = {(bone, frame) for bone, frame in spikes}
        fcurves.assign_action(arm, noisy_action)
        if has_graph_operator("gaussian_smooth"):  # Blender 4.0+
            rows.append(best_filter("Gaussian Smooth s %g, width %d", arm, noisy_action, frames, truth, noise_deg,
                                    "gaussian_smooth", GAUSS,
                                    lambda s: (dict(sigma=s[0], filter_width=s[1], factor=1.0), 1)))
        if has_graph_operator("butterworth_smooth"):  # Blender 4.2+
            rows.append(best_filter("Butterworth %g Hz, order %d", arm, noisy_action, frames, truth, noise_deg,
                                    "butterworth_smooth", BUTTER,
                                    lambda s: (dict(cutoff_frequency=s[0], filter_order=s[1], blend=1.0), 1)))
        rows.append(best_filter("Smooth x%d", arm, noisy_action, frames, truth, noise_deg, "smooth",
                                SMOOTH_PASSES, lambda s: ({}, s)))
        truth_jitter = math.degrees(np.sqrt(np.mean(np.concatenate([jitter(truth[n]) ** 2 for n in truth]))))
        print("  noise %.1f° RMS, %d spikes planted (%d found by clean, %d of them planted), sign flips every %d "
              "frames; the truth's jitter %.4f°/frame²" % (noise_deg, len(planted), len(found),
                                                            len(found & planted), FLIP_EVERY, truth_jitter))
        print("    %-40s %8s %8s %8s %8s %12s %8s" % ("method", "RMS °", "p99 °", "max °", ">3σ", "jitter °/f²",
                                                    "seconds"))
        for name, fig, seconds, _ in rows:
            print("    %-40s %8.3f %8.3f %8.2f %8d %12.4f %8.2f" % (name, fig["rms"], fig["p99"], fig["max"],
                                                                  fig["beyond"], fig["jitter"], seconds))
        best_blender = min(r[1]["rms"] for r in rows[2:])
        ours = rows[1][1]
        print("    quatcurve / noisy RMS %.2f (goal <= 0.5), / best Blender filter %.2f (goal < 1); frames beyond 3σ: %d"
              % (ours["rms"] / rows[0][1]["rms"], ours["rms"] / best_blender, ours["beyond"]))
        # the distance at the virtual vertices; quatcurve under error='DISTANCE' at its default
        fcurves.assign_action(arm, noisy_action)
        begin = time.perf_counter()
        by_distance = clean.clean([targets.Target(arm, name) for name in sorted(truth)],
                                  clean.CleanSettings(error="DISTANCE"))
        distance_seconds = time.perf_counter() - begin
        distance_action = fcurves.active_action(arm)
        distance_played = played(arm, distance_action, frames, sorted(truth))
        best = min(rows[2:], key=lambda r: r[1]["rms"])
        vertex_rows = [("noisy input", rows[0][3], rows[0][1]), (best[0], best[3], best[1]),
                       ("quatcurve clean", rows[1][3], rows[1][1]),
                       ("quatcurve clean, error DISTANCE", distance_played,
                        figures(distance_played, truth, noise_deg))]
        vertex = vertex_figures(truth_read, {name: quats for name, quats, _ in vertex_rows})
        print("    virtual vertices (shell 10 cm) against the truth; DISTANCE: bound %.2f mm (the noise's reach), "
              "%.2f mm from the noisy input at its frames that are not spikes, %.2f s" % (
                  by_distance.distance * SCALE * 1000, by_distance.worst_distance * SCALE * 1000, distance_seconds))
        print("    %-40s %8s %8s %8s %8s" % ("method", "RMS mm", "max mm", "RMS °", "max °"))
        for name, _, fig in vertex_rows:
            print("    %-40s %8.2f %8.1f %8.3f %8.2f" % (name, *vertex[name], fig["rms"], fig["max"]))
        fcurves.assign_action(arm, noisy_action)
        fcurves.remove_action(distance_action)
        if picture and k == len(NOISE_DEG) - 1:
            bone = max(spikes.items(), key=lambda item: item[1])[0][0]
            best = min(rows[2:], key=lambda r: r[1]["rms"])
            draw_picture(picture, os.path.basename(path), bone, frames, truth, noise_deg,
                         [("noisy input", rows[0][3]), (best[0], best[3]), ("quatcurve clean", rows[1][3])])
        fcurves.assign_action(arm, original)
        for action in (noisy_action, cleaned):
            fcurves.remove_action(action)


def main():
    paths = [os.path.join(MOCAP, c) for c in CLIPS if os.path.exists(os.path.join(MOCAP, c))]
    if not paths:
        print("skipped: the shared mocap clips are absent (%s)" % os.path.relpath(MOCAP, ROOT))
        return
    args = smoke.script_args()
    picture = args[args.index("--picture") + 1] if "--picture" in args else None
    with tempfile.TemporaryDirectory() as folder:
        for k, path in enumerate(paths[:1] if smoke.SMOKE else paths):
            bench_clip(path, folder, picture if k == 0 else None)


smoke.run(main)
