"""Export to glTF that plays the curve: Blender's own glTF exporter writes the scene, then every
rotation sampler it wrote is replaced by glTF LINEAR keys (slerp, by the glTF specification) that
stay within the tolerance of the target's curve, as few as a greedy search finds.

    result = gltf.export(bpy.context.scene, "out.glb", gltf.ExportSettings(method="AUTO", tolerance=0.1))
    print(result.summary())

The curve of each target (object or pose bone):
  AUTO     a fitted target: its fit's method (and settings, eases, turns) through the animator's keys; any
           other target: what Blender plays (its rotation F-curves evaluated by Blender).
  BLENDER  what Blender plays, for every target.
  a method (SLERP, SQUAD, ...): that method through the target's keys (a fitted target keeps its fit's
           other settings, eases and turns).

The glTF node's rotation is not the target's channel rotation: the exporter converts axes (Y up) and
expresses bones relative to their parent's rest pose. For a node whose rotation comes from its
channels only, the two differ by fixed rotations on both sides, g(t) = A·q(t)·B (B: the exporter's
axis conversion, or none). The exporter's own output finds them: it is exported sampled at every
frame, and A, B are taken from its first sample and checked on every sample (within MAP_TOLERANCE)
against Blender's evaluation of the channels there. A node that fails the check (constraints,
drivers, a parent's non-uniform scale, NLA: anything but the channels moving it) keeps the sampler
the exporter wrote, and the result says so. The curve, sampled `subframes` times per frame over the
sampler's frames (times as the file stores them, float32 seconds), is then reduced by the native
`quatcurve.reduce_slerp_proved` to few keys (a greedy search) whose slerp is proved within the
tolerance of the curve at every instant (slerp is bi-invariant: the node's A·q·B of them plays the
same motion turned); where the curve is Blender's playback of keys quatcurve does not emulate, the
keys hold at the samples (`reduce_slerp`) and the result says so. Translations, scales, meshes,
skins: as the exporter wrote them.

A loop (cycles.py: Cycles modifiers on the target's rotation channels) is written as exactly one
period, its first key to its last ([t0, t0 + P] in seconds), reduced as a closed curve
(`cyclic=True`), the last key stored equal to the first: a player that wraps the
clip's time (three.js LoopRepeat, Unity's Loop Time) plays through the seam without a step or a
held frame.

Nothing is written on error: the exporter writes a temporary file next to the output, the rewrite
another, which is renamed over the output last. Errors raise GltfError naming the target or file.
"""

import math
import os
import tempfile
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import cycles, fcurves, fit, glb, methods, native, reduce, targets
from .targets import TargetError

METHODS = ("AUTO", "BLENDER") + fit.METHODS
# Largest angle (radians) between the exporter's sample and A·q·B for the map to be taken as exact:
# both sides are float32 (the file, Blender's matrices), ~1e-6 rad apart.
MAP_TOLERANCE = 1e-4
# The keys are verified against the samples below the tolerance by this much (radians): the reader's
# slerp at times between the samples, float32 times and quaternions.
MARGIN = 1e-5
# What rounding a unit quaternion to float32 can move it (radians; 4 components, half an ulp each).
FLOAT32_QUAT = 1e-6
# The exporter's axis conversion (Blender Z up -> glTF Y up): -90° about X; (w, x, y, z) -> (w, x, z, -y).
Y_UP = np.array([math.sqrt(0.5), -math.sqrt(0.5), 0.0, 0.0])


class GltfError(TargetError):
    """An export that cannot be done; the message names the file, target or setting. Nothing is written."""


@dataclass
class ExportSettings:
    """method: AUTO, BLENDER or a fit method (see the module); tolerance: degrees, largest angle between
    the file's slerp and the curve at every checked point; subframes: checked points per frame."""
    method: str = "AUTO"
    tolerance: float = 0.1
    subframes: int = 20


def check_settings(settings, filepath):
    if settings.method not in METHODS:
        raise GltfError("method %r: unknown (methods: %s)" % (settings.method, ", ".join(METHODS)))
    if not (settings.tolerance > 0) or not math.isfinite(settings.tolerance):
        raise GltfError("tolerance %r°: must be a finite angle above 0" % (settings.tolerance,))
    if int(settings.subframes) != settings.subframes or not 1 <= settings.subframes <= 100:
        raise GltfError("subframes %r: must be a whole number from 1 to 100" % (settings.subframes,))
    if not filepath or not str(filepath).lower().endswith(".glb"):
        raise GltfError("%r: the output must be a binary glTF file ending in .glb" % (filepath,))
    folder = os.path.dirname(os.path.abspath(filepath))
    if os.path.isdir(filepath):
        raise GltfError("%s: is a folder" % filepath)
    if not os.path.isdir(folder):
        raise GltfError("%s: the folder %s does not exist" % (filepath, folder))
    if not os.access(folder, os.W_OK):
        raise GltfError("%s: the folder %s is not writable" % (filepath, folder))


@dataclass
class SamplerResult:
    """One rotation sampler: the node and target, keys before (the exporter's) and after, the largest
    error (radians) of the written keys against the curve over the checked points, and what the
    curve was (or why the sampler was left as the exporter wrote it)."""
    animation: str
    node: str
    target: str
    keys_before: int
    keys_after: int
    max_error: float
    curve: str
    rewritten: bool = True


@dataclass
class ExportResult:
    filepath: str
    settings: ExportSettings
    samplers: list = field(default_factory=list)
    size: int = 0

    @property
    def keys_before(self):
        return sum(s.keys_before for s in self.samplers)

    @property
    def keys_after(self):
        return sum(s.keys_after for s in self.samplers)

    @property
    def max_error(self):
        return max([s.max_error for s in self.samplers if s.rewritten] or [0.0])

    def summary(self):
        kept = sum(not s.rewritten for s in self.samplers)
        return ("Exported %s: %d rotation samplers, %d keys (sampled: %d), max error %.4f° (tolerance %g°), "
                "%d bytes%s" % (os.path.basename(self.filepath), len(self.samplers), self.keys_after,
                                self.keys_before, math.degrees(self.max_error), self.settings.tolerance,
                                self.size, ", %d left as sampled" % kept if kept else ""))

    def lines(self):
        return ["%s: %d -> %d keys, %s%s" % (s.target or s.node, s.keys_before, s.keys_after,
                                              ("max error %.4f°, " % math.degrees(s.max_error)) if s.rewritten else "",
                                              s.curve) for s in self.samplers]


# ---- the exporter ------------------------------------------------------------------------------------

def exporter_options():
    """The options quatcurve passes to bpy.ops.export_scene.gltf, those the running Blender has: a .glb,
    animations sampled at every frame, the active actions as one animation (4.x: ACTIVE_ACTIONS;
    3.4: no NLA strips), times not shifted."""
    wanted = dict(export_format="GLB", export_animations=True, export_force_sampling=True, export_frame_step=1,
                  export_animation_mode="ACTIVE_ACTIONS", export_nla_strips=False, export_anim_slide_to_zero=False,
                  export_current_frame=False)
    have = bpy.ops.export_scene.gltf.get_rna_type().properties
    return {k: v for k, v in wanted.items() if k in have}


def run_exporter(filepath, **options):
    """Blender's glTF exporter writing `filepath` (the options it has among `options`)."""
    have = bpy.ops.export_scene.gltf.get_rna_type().properties
    result = bpy.ops.export_scene.gltf(filepath=filepath, **{k: v for k, v in options.items() if k in have})
    if "FINISHED" not in result or not os.path.isfile(filepath):
        raise GltfError("%s: Blender's glTF exporter did not write the file (%s)" % (filepath, ", ".join(result)))


# ---- nodes and targets -----------------------------------------------------------------------------------

def node_targets(doc, scene):
    """{node index: targets.Target} for the glTF nodes that are the scene's objects and their pose
    bones (the exporter names nodes after them; bones are found under their armature's node first)."""
    nodes = doc.get("nodes", [])
    found = {}
    for i, node in enumerate(nodes):
        obj = scene.objects.get(node.get("name", ""))
        if obj is None or obj.type != "ARMATURE" or obj.pose is None:
            continue
        todo = list(node.get("children", []))
        while todo:
            c = todo.pop()
            name = nodes[c].get("name", "")
            if name in obj.pose.bones and c not in found:
                found[c] = targets.Target(obj, name)
                todo += nodes[c].get("children", [])
    for i, node in enumerate(nodes):
        obj = scene.objects.get(node.get("name", ""))
        if i not in found and obj is not None:
            found[i] = targets.Target(obj)
    return found


# ---- curves -----------------------------------------------------------------------------------------------

def playback(target, frames):
    """(N, 4) the rotation (w, x, y, z) Blender plays from the target's rotation channels at `frames`:
    its active action's F-curves in its rotation mode evaluated by Blender (an unkeyed channel holds
    its value; with no active action, the NLA strips playing on it)."""
    action = fcurves.active_action(target.id_data)
    return targets.playback(target, action).quats(np.asarray(frames, dtype=np.float64))


def reference(target, settings):
    """(the target's curve under `settings`, description): a native Curve (a method through the keys),
    or a function frames -> (N, 4) quaternions (Blender's playback)."""
    action = fcurves.active_action(target.id_data)
    record = fit.find_record(action, target) if action is not None else None
    if settings.method == "BLENDER" or (settings.method == "AUTO" and record is None):
        return (lambda frames: playback(target, frames)), "Blender's playback"
    keys = fit.read_animator_keys(target)
    if len(keys.frames) < 2:
        return (lambda frames: playback(target, frames)), "Blender's playback (fewer than two keys)"
    fit_settings = fit.settings_of(record) if record is not None else fit.FitSettings()
    if settings.method != "AUTO":
        fit_settings.method = settings.method
    ease_in, ease_out, turns = fit.refit_eases(keys, target, record)
    if keys.mode != "QUATERNION":
        turns = None  # as the fit: Euler and axis-angle keys carry their turns in their angles
    curve, _ = fit.curve_of(keys, fit_settings, ease_in, ease_out, turns)
    how = "%s through %d keys%s" % (methods.label(fit_settings.method), len(keys.frames),
                                    " (fitted)" if record is not None else "")
    return curve, how


def proof_reference(target, curve, frames, loop):
    """What the written keys are proved against at every instant: the method's native Curve, or
    (channels, interpolation, mode) of the rotation F-curves whose playback quatcurve emulates
    (reduce.read_original) — or None and why not (NLA, other interpolations, modifiers on an open
    target: a loop's Cycles modifier changes nothing inside its period)."""
    if not callable(curve):
        return curve, ""
    action = fcurves.active_action(target.id_data)
    played = targets.playback(target, action)
    if loop is None and any(fc is not None and len(fc.modifiers) for fc in played.fcurves):
        return None, "F-curve modifiers on its rotation"
    original, why = reduce.read_original(played, frames)
    if original is None:
        return None, why
    return (original[0], original[1], target.owner.rotation_mode), ""


def node_map(exported, played):
    """(A, B, residual): fixed rotations with exported ≈ A·played·B at every sample (either sign), B the
    exporter's axis conversion or none, A from the first sample; residual: the largest angle left."""
    qc = native.require()
    best = None
    for b in (qc.quat_conjugate(Y_UP), np.array([1.0, 0.0, 0.0, 0.0])):
        a = qc.quat_multiply(qc.quat_multiply(exported[0], qc.quat_conjugate(b)), qc.quat_conjugate(played[0]))
        a = a / np.linalg.norm(a)
        mapped = qc.quat_multiply(qc.quat_multiply(a, played), b)
        residual = float(np.max(qc.angle_between(mapped, exported)))
        if best is None or residual < best[2]:
            best = (a, b, residual)
    return best


# ---- the rewrite --------------------------------------------------------------------------------------------

def rewrite_sampler(doc, sampler, target, settings, fps):
    """The new keys of one rotation sampler (times in seconds, (K, 4) x, y, z, w; float32) and its
    SamplerResult fields, or the reason it is kept (a string)."""
    qc = native.require()
    times = doc.accessor_array(sampler["input"])[:, 0]
    exported = doc.accessor_array(sampler["output"])[:, [3, 0, 1, 2]]  # glTF x, y, z, w -> w, x, y, z
    if sampler.get("interpolation", "LINEAR") == "CUBICSPLINE" or len(times) != len(exported):
        return "kept: a CUBICSPLINE sampler"
    frames = times * fps
    whole = np.round(frames)
    frames = np.where(np.abs(frames - whole) < 1e-3, whole, frames)  # float32 seconds -> the exporter's frames
    # The target's curve first: keys a method cannot be built from are refused whatever the exporter
    # wrote for them.
    curve, how = reference(target, settings)
    try:
        loop = cycles.loop_of(target)
    except cycles.CycleError:
        if not how.startswith("Blender's playback"):
            raise
        loop = None  # Blender's playback of any modifiers, over the exporter's frames, as before
    played = playback(target, frames)
    a, b, residual = node_map(exported, played)
    if residual > MAP_TOLERANCE:
        return ("kept as sampled: the exported rotation is not the rotation channels' (%.3g° apart at best: "
                "constraints, drivers, NLA or a parent's scale move it)" % math.degrees(residual))
    if loop is not None:  # one period: the first key to the last
        frames = np.array([loop.start, loop.end])
        how += ", one period of a loop (frames %s–%s)" % (targets.num(loop.start), targets.num(loop.end))
    step = 1.0 / settings.subframes
    dense = frames[0] + step * np.arange(int(round((frames[-1] - frames[0]) / step)) + 1)
    dense[-1] = frames[-1]
    # The times the file stores (float32 seconds), as frames.
    t32 = (dense / fps).astype(np.float32).astype(np.float64)
    t32 = t32[np.concatenate(([True], t32[1:] > t32[:-1]))]  # float32 may merge very close times
    tolerance = math.radians(settings.tolerance)
    proved_against, why = proof_reference(target, curve, t32 * fps, loop)
    if proved_against is not None:
        # Proved at every instant in the channels' own rotation: slerp is bi-invariant, so the file's
        # keys A·q·B play the same motion turned. The keys sit on times the file stores exactly.
        if isinstance(proved_against, tuple):
            channels, ipo, mode = proved_against
            proved = qc.reduce_slerp_proved(channels, ipo, mode, t32 * fps, max(tolerance - MARGIN, 0.0),
                                            cyclic=loop is not None, file_unit=1.0 / fps)
        else:
            proved = qc.reduce_slerp_proved(proved_against, t32 * fps, max(tolerance - MARGIN, 0.0),
                                            cyclic=loop is not None, file_unit=1.0 / fps)
        key_times = (proved.key_times / fps).astype(np.float32).astype(np.float64)
        kept = qc.quat_multiply(qc.quat_multiply(a, proved.keys.quats), b)
        # float32 quaternions: within 1e-6 rad of the exact keys (MARGIN's room).
        error = proved.proof.bound + FLOAT32_QUAT
        how += ", at every instant" if proved.proof.proven else ", at every instant within %.4f°" % math.degrees(error)
        if len(proved.excluded):
            how += (" but inside %d sign flip%s of its quaternion keys, where Blender turns through the flip and the "
                    "file takes the short way" % (len(proved.excluded), "" if len(proved.excluded) == 1 else "s"))
    else:
        sample = curve if callable(curve) else curve.sample
        quats = qc.quat_multiply(qc.quat_multiply(a, np.asarray(sample(t32 * fps), dtype=np.float64)), b)
        quats = quats / np.linalg.norm(quats, axis=1, keepdims=True)
        q32 = quats.astype(np.float32).astype(np.float64)
        keys = qc.reduce_slerp(t32, q32, max(tolerance - MARGIN, 0.0), cyclic=loop is not None)
        key_times, kept, error = t32[keys.indices], keys.quats, keys.max_error
        how += ", at the checked points (between them not proved: %s)" % why
    kept = kept / np.linalg.norm(kept, axis=1, keepdims=True)
    for k in range(1, len(kept)):  # one hemisphere chain, as reduce_slerp gives them
        if np.dot(kept[k], kept[k - 1]) < 0:
            kept[k] = -kept[k]
    if loop is not None:
        # The same key at both ends, as a wrapping player expects (glTF's slerp takes the short way,
        # so the other sign of the same rotation plays the same).
        kept[-1] = kept[0]
    out = kept.astype(np.float32)[:, [1, 2, 3, 0]]  # w, x, y, z -> glTF x, y, z, w
    return key_times, out, error, how


def rewrite(doc, scene, settings, fps):
    """Replaces the rotation samplers of `doc` in place; returns the SamplerResults."""
    mapped = node_targets(doc.json, scene)
    nodes = doc.json.get("nodes", [])
    users = {}
    for anim in doc.json.get("animations", []):
        for sampler in anim["samplers"]:
            for key in ("input", "output"):
                users[sampler[key]] = users.get(sampler[key], 0) + 1
    view_users = {}
    for acc in doc.json.get("accessors", []):
        if "bufferView" in acc:
            view_users[acc["bufferView"]] = view_users.get(acc["bufferView"], 0) + 1
    for image in doc.json.get("images", []):
        if "bufferView" in image:
            view_users[image["bufferView"]] = view_users.get(image["bufferView"], 0) + 2
    results = []
    plans = []
    for anim in doc.json.get("animations", []):
        for channel in anim["channels"]:
            node = channel["target"].get("node")
            if channel["target"].get("path") != "rotation" or node is None:
                continue
            sampler = anim["samplers"][channel["sampler"]]
            count = doc.json["accessors"][sampler["input"]]["count"]
            name = nodes[node].get("name", "node %d" % node)
            target = mapped.get(node)
            if target is None:
                results.append(SamplerResult(anim.get("name", ""), name, "", count, count, 0.0,
                                             "kept: no object or bone of the scene has this name", False))
                continue
            try:
                planned = rewrite_sampler(doc, sampler, target, settings, fps)
            except TargetError as e:
                raise GltfError(str(e)) from None
            except ValueError as e:
                raise GltfError("%s: %s" % (target.name, e)) from None
            if isinstance(planned, str):
                results.append(SamplerResult(anim.get("name", ""), name, target.name, count, count, 0.0, planned, False))
                continue
            times, quats, error, how = planned
            results.append(SamplerResult(anim.get("name", ""), name, target.name, count, len(times), error, how))
            plans.append((sampler, times, quats))
    # Key times already stored (the exporter's inputs, and ours as they are written): samplers with
    # the same times share one input accessor (still motion keeps its first and last sample).
    inputs = {}
    for anim in doc.json.get("animations", []):
        for sampler in anim["samplers"]:
            try:
                inputs.setdefault(doc.accessor_array(sampler["input"]).astype("<f4").tobytes(), sampler["input"])
            except glb.GlbError:
                pass
    for sampler, times, quats in plans:
        sampler["interpolation"] = "LINEAR"
        known = inputs.get(np.asarray(times, dtype="<f4").tobytes())
        if known is not None:
            users[sampler["input"]] -= 1
            sampler["input"] = known
            users[known] = users.get(known, 0) + 1
        for key, values, kind, bounds in (("input", times, "SCALAR", True), ("output", quats, "VEC4", False)):
            if key == "input" and known is not None:
                continue
            old = sampler[key]
            users[old] -= 1
            view = doc.json["accessors"][old].get("bufferView")
            if users[old] == 0:  # this sampler was its last user: the accessor (and its own view) is reused
                users[old] = 1
                for stale in [b for b, i in inputs.items() if i == old]:  # its old times are gone
                    del inputs[stale]
                own = view if view is not None and view_users.get(view) == 1 else None
                doc.set_accessor(old, values, kind, bounds=bounds, view=own, packed=own is None)
            else:
                sampler[key] = doc.add_accessor(values, kind, bounds=bounds, packed=True)
                users[sampler[key]] = 1
            if key == "input":
                inputs[np.asarray(values, dtype="<f4").tobytes()] = sampler[key]
    return results


def export(scene, filepath, settings=None):
    """Exports `scene` to `filepath` (.glb) with Blender's glTF exporter, rotation samplers replaced
    (module docstring); returns an ExportResult. Raises GltfError, leaving `filepath` untouched."""
    settings = settings or ExportSettings()
    check_settings(settings, filepath)
    native.require()
    if scene != bpy.context.scene:
        raise GltfError("scene '%s': the exporter exports the current scene ('%s')" % (scene.name, bpy.context.scene.name))
    if not len(scene.objects):
        raise GltfError("Nothing to export: the scene '%s' has no objects" % scene.name)
    filepath = os.path.abspath(filepath)
    folder = os.path.dirname(filepath)
    fps = scene.render.fps / scene.render.fps_base
    fd, sampled = tempfile.mkstemp(prefix=".quatcurve-", suffix=".glb", dir=folder)
    os.close(fd)
    fd, rewritten = tempfile.mkstemp(prefix=".quatcurve-", suffix=".glb", dir=folder)
    os.close(fd)
    try:
        run_exporter(sampled, **exporter_options())
        try:
            doc = glb.read(sampled)
        except glb.GlbError as e:
            raise GltfError(str(e)) from None
        with fit.record_index():
            results = rewrite(doc, scene, settings, fps)
        glb.write(doc, rewritten)
        os.replace(rewritten, filepath)
    finally:
        for path in (sampled, rewritten):
            if os.path.exists(path):
                os.remove(path)
    return ExportResult(filepath, settings, results, os.path.getsize(filepath))
