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
frame, and A, B are taken from its first sample and checked on every sample (within MAP_TOLERANCE;
where samples cannot tell the two B apart, an object's is the Y-up turn and a bone's none)
against Blender's evaluation of the channels there. A node that fails the check (constraints,
drivers, a parent's non-uniform scale, NLA: anything but the channels moving it) keeps the sampler
the exporter wrote, and the result says so. The curve, sampled `subframes` times per frame over the
sampler's frames (times as the file stores them, float32 seconds; on to a last rotation key at a
fractional frame past them, which the exporter's whole frames stop short of), is then reduced by the
native `quatcurve.reduce_slerp_proved` to few keys (a greedy search) whose slerp is proved within the
tolerance of the curve at every instant (slerp is bi-invariant: the node's A·q·B of them plays the
same motion turned); where the curve is Blender's playback of keys quatcurve does not emulate, the
keys hold at the samples (`reduce_slerp`) and the result says so. Blocking keys (every rotation key
CONSTANT, Blender's playback) become a STEP sampler keyed where they step (blocking_steps).
Translations, scales, meshes, skins: as the exporter wrote them.

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
    the file's slerp and the curve at every instant; subframes: candidate key times per frame.
    error: ANGLE (the tolerance per rotation sampler) or DISTANCE (per armature, every bone's virtual
    vertices within `distance` of the curve's pose, the bone's angle budgets chosen for it; each
    object its own three shell points); distance, shell: scene units, 0 the defaults (1 mm at 10 cm
    in real size, as reduce.scene_lengths)."""
    method: str = "AUTO"
    tolerance: float = 0.1
    subframes: int = 20
    error: str = "ANGLE"
    distance: float = 0.0
    shell: float = 0.0


def check_settings(settings, filepath):
    if settings.method not in METHODS:
        raise GltfError("method %r: unknown (methods: %s)" % (settings.method, ", ".join(METHODS)))
    if not (settings.tolerance > 0) or not math.isfinite(settings.tolerance):
        raise GltfError("tolerance %r°: must be a finite angle above 0" % (settings.tolerance,))
    if settings.error not in reduce.ERRORS:
        raise GltfError("error %r: unknown (expected ANGLE or DISTANCE)" % (settings.error,))
    for name in ("distance", "shell"):
        value = getattr(settings, name)
        if not (value >= 0) or not math.isfinite(value):
            raise GltfError("%s %r: must be a finite length of 0 or more (0: the default)" % (name, value))
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
class DistanceResult:
    """The distance bound of one armature (or object) in the file: its worst virtual-vertex distance
    (scene units) at the checked frames, where, and its text in the scene's units."""
    name: str
    distance: float
    bone: str
    frame: float
    vertex: str
    text: str
    bound_text: str


@dataclass
class ExportResult:
    filepath: str
    settings: ExportSettings
    samplers: list = field(default_factory=list)
    size: int = 0
    distances: list = field(default_factory=list)  # DistanceResult per armature or object (error DISTANCE)

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
        if self.settings.error == "DISTANCE":
            worst = max(self.distances, key=lambda d: d.distance, default=None)
            bound = ("worst distance %s (bound %s) at %s frame %s" % (
                worst.text, worst.bound_text, worst.name if worst.bone == worst.name else
                "%s/%s" % (worst.name, worst.bone), targets.num(worst.frame)) if worst else "no armature or object")
        else:
            bound = "max error %.4f° (tolerance %g°)" % (math.degrees(self.max_error), self.settings.tolerance)
        return ("Exported %s: %d rotation samplers, %d keys (sampled: %d), %s, %d bytes%s" % (
            os.path.basename(self.filepath), len(self.samplers), self.keys_after, self.keys_before, bound, self.size,
            ", %d left as sampled" % kept if kept else ""))

    def lines(self):
        out = ["%s: worst distance %s (bound %s) at %s frame %s, %s" % (
            d.name, d.text, d.bound_text, d.bone, targets.num(d.frame), d.vertex) for d in self.distances]
        return out + ["%s: %d -> %d keys, %s%s" % (s.target or s.node, s.keys_before, s.keys_after,
                                                    ("max error %.4f°, " % math.degrees(s.max_error)) if s.rewritten
                                                    else "", s.curve) for s in self.samplers]


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


def node_map(exported, played, is_object=True):
    """(A, B, residual): fixed rotations with exported ≈ A·played·B at every sample (either sign), B the
    exporter's axis conversion or none, A from the first sample; residual: the largest angle left.
    Where both fit (one sample, or samples that do not tell them apart), B is what the exporter does:
    an object's rotation is turned to Y up on both sides (B = Y_UP⁻¹), a bone's is not (B = 1)."""
    qc = native.require()
    fits = []
    for b in (qc.quat_conjugate(Y_UP), np.array([1.0, 0.0, 0.0, 0.0])):
        a = qc.quat_multiply(qc.quat_multiply(exported[0], qc.quat_conjugate(b)), qc.quat_conjugate(played[0]))
        a = a / np.linalg.norm(a)
        mapped = qc.quat_multiply(qc.quat_multiply(a, played), b)
        fits.append((a, b, float(np.max(qc.angle_between(mapped, exported)))))
    if all(f[2] <= MAP_TOLERANCE for f in fits):
        return fits[0] if is_object else fits[1]
    return min(fits, key=lambda f: f[2])


# ---- the rewrite --------------------------------------------------------------------------------------------

@dataclass(eq=False)
class SamplerPlan:
    """One rotation sampler to rewrite: its target, the node's maps (node = A·q·B), the target's
    curve (a native Curve or a function frames -> quaternions) and its description, the candidate
    key times (frames the file stores exactly), and what the keys are proved against (a Curve,
    (channels, interpolation, mode) of a playback quatcurve emulates, or None and why not)."""
    target: object
    a: np.ndarray
    b: np.ndarray
    loop: object
    curve: object
    how: str
    frames: np.ndarray
    proved_against: object
    why: str
    fps: float
    steps: np.ndarray = None  # blocking keys (blocking_steps): the frames a STEP sampler keys

    def sample(self, frames):
        """The target's curve at `frames`, (N, 4) in the channels' own rotation."""
        sample = self.curve if callable(self.curve) else self.curve.sample
        return np.asarray(sample(np.asarray(frames, dtype=np.float64)), dtype=np.float64)

    def slerp_bone(self):
        """The native SlerpBone of this sampler (the distance mode's per-bone reduction)."""
        qc = native.require()
        if self.proved_against is None:
            return qc.SlerpBone(self.frames, samples=self.sample(self.frames), cyclic=self.loop is not None)
        return qc.SlerpBone(self.frames, reference=self.proved_against, cyclic=self.loop is not None, file_unit=1.0 / self.fps)


def exporter_slides(scene):
    """Whether Blender's exporter slides the scene's animation in time: an active action whose range
    starts at frame -1 or before (the exporter truncates the start toward 0, as int()), and an exporter
    with the option (export_negative_frame, default SLIDE: glTF has no negative times), which then
    shifts every sampler so the earliest frame it writes is at 0 s."""
    if "export_negative_frame" not in bpy.ops.export_scene.gltf.get_rna_type().properties:
        return False
    for obj in scene.objects:
        action = fcurves.active_action(obj)
        if action is not None and int(action.frame_range[0]) < 0:
            return True
    return False


def plan_sampler(doc, sampler, target, settings, fps, slid=False):
    """The SamplerPlan of one rotation sampler, or the reason it is kept as the exporter wrote it
    (slid: exporter_slides)."""
    times = doc.accessor_array(sampler["input"])[:, 0]
    exported = doc.accessor_array(sampler["output"])[:, [3, 0, 1, 2]]  # glTF x, y, z, w -> w, x, y, z
    if sampler.get("interpolation", "LINEAR") == "CUBICSPLINE" or len(times) != len(exported):
        return "kept: a CUBICSPLINE sampler"
    if slid:
        return ("kept as sampled: an action starts before frame 0, so Blender's exporter slid the animation to "
                "start at 0 s and the file's times are not the scene's frames (move the keys to frame 0 or later)")
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
    a, b, residual = node_map(exported, played, is_object=target.bone is None)
    if residual > MAP_TOLERANCE:
        bone = target.object.data.bones[target.bone] if target.bone is not None else None
        if bone is not None and bone.parent is not None and not (bone.use_inherit_rotation and
                                                                 bone.inherit_scale == "FULL"):
            cause = ("Inherit Rotation off" if not bone.use_inherit_rotation else
                     "inherit scale %s" % bone.inherit_scale) + ": the exporter writes its pose relative to its parent's"
        elif target.bone is None and target.object.parent is not None and \
                target.object.parent.type in ("CAMERA", "LIGHT"):
            cause = ("a child of the %s %s: the exporter turns the parent's axes to glTF's %s convention, and the "
                     "child's against them" % (target.object.parent.type.lower(), target.object.parent.name,
                                               target.object.parent.type.lower()))
        else:
            cause = "constraints, drivers, NLA or a parent's scale move it"
        return ("kept as sampled: the exported rotation is not the rotation channels' (%.3g° apart at best: %s)"
                % (math.degrees(residual), cause))
    if loop is not None:  # one period: the first key to the last
        frames = np.array([loop.start, loop.end])
        how += ", one period of a loop (frames %s–%s)" % (targets.num(loop.start), targets.num(loop.end))
    else:
        last = rotation_end(target)
        if frames[-1] < last < frames[-1] + 1.0:
            # The exporter samples whole frames and stops at the last one before a fractional last key;
            # from there Blender turns on to the key and holds it, so the file's keys go on to it too.
            frames = np.append(frames, last)
    if len(frames) < 2:
        return "kept: one sample (the rotation the exporter wrote for the animation's only frame)"
    span = frames[0], frames[-1]  # the exporter's frames (the loop's period), before float32 seconds
    step = 1.0 / settings.subframes
    # Every subframe from the first frame, and the last frame: a last key off the grid (10.6 after 10.5,
    # or 3.25 a quarter frame after 3 at one sample a frame) is added, never put in a subframe's place.
    dense = frames[0] + step * np.arange(int(math.floor((frames[-1] - frames[0]) / step + 1e-9)) + 1)
    if frames[-1] - dense[-1] > 1e-9:
        dense = np.append(dense, frames[-1])
    else:
        dense[-1] = frames[-1]
    # The times the file stores (float32 seconds), as frames.
    t32 = (dense / fps).astype(np.float32).astype(np.float64)
    t32 = t32[np.concatenate(([True], t32[1:] > t32[:-1]))]  # float32 may merge very close times
    proved_against, why = proof_reference(target, curve, t32 * fps, loop)
    steps = blocking_steps(target, *span) if callable(curve) and loop is None else None
    return SamplerPlan(target, a, b, loop, curve, how, t32 * fps, proved_against, why, fps, steps)


def rotation_end(target):
    """The frame of the last key on the target's rotation channels in its active action, or the end of
    the action's manual frame range if that comes first (the exporter's range: the clip ends there);
    -inf without keys."""
    action = fcurves.active_action(target.id_data)
    frames = fcurves.key_frames(targets.playback(target, action).fcurves)
    if not len(frames):
        return -math.inf
    if getattr(action, "use_frame_range", False):
        return min(float(frames[-1]), float(action.frame_range[1]))
    return float(frames[-1])


def blocking_steps(target, first, last):
    """Where the rotation of a target keyed with blocking keys steps, as the frames of a glTF STEP
    sampler: `first` and every rotation key frame in (first, last] — or None unless every segment of
    every rotation F-curve is CONSTANT (no modifiers, constant extrapolation, no NLA). Between those
    frames Blender holds the last key's rotation, as STEP holds its last key's value."""
    played = targets.playback(target, fcurves.active_action(target.id_data))
    present = [fc for fc in played.fcurves if fc is not None]
    kinds = [fcurves.segment_interpolations(fc) for fc in present]
    if (played.nla or not present or not any(kinds) or not all(k <= {"CONSTANT"} for k in kinds)
            or any(fc.extrapolation != "CONSTANT" or len(fc.modifiers) for fc in present)):
        return None
    keyed = fcurves.key_frames(present)
    return np.concatenate(([first], keyed[(keyed > first) & (keyed <= last)]))


def step_keys(plan):
    """Blocking keys (plan.steps): the held rotation at each step, written as a STEP sampler (in either
    error mode: the same rotation at every instant, so nothing to budget)."""
    seconds = step_seconds(plan.steps, plan.fps)
    # Steps closer than float32 seconds tell apart: the last of them holds from that time on.
    frames = plan.steps[np.append(seconds[1:] > seconds[:-1], True)]
    merged = len(plan.steps) - len(frames)
    return (frames, plan.sample(frames), FLOAT32_QUAT,
            plan.how + ", STEP keys at the %d frames where it steps (blocking keys): the same rotation at every "
            "instant, each step at its frame or one float32 step of its time before it%s" % (
                len(frames), "; %d steps closer than that to the next merged into it" % merged if merged else ""))


def step_seconds(frames, fps):
    """A STEP sampler's key times as the file stores them: float32 seconds at or before each frame, so
    a player at a step's frame already holds its key (float64 array)."""
    seconds = np.asarray(frames, dtype=np.float64) / fps
    stored = seconds.astype(np.float32)
    late = stored.astype(np.float64) > seconds
    stored[late] = np.nextafter(stored[late], np.float32(-np.inf))
    return stored.astype(np.float64)


def reduce_sampler(plan, settings):
    """(key frames, (K, 4) keys in the channels' rotation, error bound (radians), description): the
    sampler's keys within the tolerance of its curve (ANGLE)."""
    qc = native.require()
    tolerance = max(math.radians(settings.tolerance) - MARGIN, 0.0)
    how = plan.how
    if plan.steps is not None:
        return step_keys(plan)
    if plan.proved_against is not None:
        # Proved at every instant in the channels' own rotation: slerp is bi-invariant, so the file's
        # keys A·q·B play the same motion turned. The keys sit on times the file stores exactly.
        if isinstance(plan.proved_against, tuple):
            channels, ipo, mode = plan.proved_against
            proved = qc.reduce_slerp_proved(channels, ipo, mode, plan.frames, tolerance, cyclic=plan.loop is not None,
                                            file_unit=1.0 / plan.fps)
        else:
            proved = qc.reduce_slerp_proved(plan.proved_against, plan.frames, tolerance,
                                            cyclic=plan.loop is not None, file_unit=1.0 / plan.fps)
        return proved.key_times, proved.keys.quats, proved.proof.bound + FLOAT32_QUAT, how + proof_text(proved)
    # Held at the samples: the node's rotation as the file stores it (float32), reduced there.
    quats = qc.quat_multiply(qc.quat_multiply(plan.a, plan.sample(plan.frames)), plan.b)
    quats = quats / np.linalg.norm(quats, axis=1, keepdims=True)
    q32 = quats.astype(np.float32).astype(np.float64)
    t32 = plan.frames / plan.fps
    keys = qc.reduce_slerp(t32, q32, tolerance, cyclic=plan.loop is not None)
    back = qc.quat_multiply(qc.quat_multiply(qc.quat_conjugate(plan.a), keys.quats), qc.quat_conjugate(plan.b))
    return (plan.frames[keys.indices], back, keys.max_error,
            how + ", at the checked points (between them not proved: %s)" % plan.why)


def proof_text(proved):
    """How far a ProvedSlerpKeys holds, for the sampler's line."""
    error = proved.proof.bound + FLOAT32_QUAT
    text = ", at every instant" if proved.proof.proven else ", at every instant within %.4f°" % math.degrees(error)
    if len(proved.excluded):
        text += (" but inside %d sign flip%s of its quaternion keys, where Blender turns through the flip and the "
                 "file takes the short way" % (len(proved.excluded), "" if len(proved.excluded) == 1 else "s"))
    return text


def sampler_keys(plan, key_frames, keys):
    """(key times in seconds, (K, 4) float32 glTF x, y, z, w): `keys` (the channels' rotation) turned
    into the node's (A·q·B), one hemisphere chain, a loop's last key its first."""
    qc = native.require()
    key_times = (step_seconds(key_frames, plan.fps) if plan.steps is not None else
                 (np.asarray(key_frames, dtype=np.float64) / plan.fps).astype(np.float32).astype(np.float64))
    kept = qc.quat_multiply(qc.quat_multiply(plan.a, np.asarray(keys, dtype=np.float64)), plan.b)
    kept = kept / np.linalg.norm(kept, axis=1, keepdims=True)
    for k in range(1, len(kept)):  # one hemisphere chain, as reduce_slerp gives them
        if np.dot(kept[k], kept[k - 1]) < 0:
            kept[k] = -kept[k]
    if plan.loop is not None:
        # The same key at both ends, as a wrapping player expects (glTF's slerp takes the short way,
        # so the other sign of the same rotation plays the same).
        kept[-1] = kept[0]
    return key_times, kept.astype(np.float32)[:, [1, 2, 3, 0]]  # w, x, y, z -> glTF x, y, z, w


# ---- the distance bound (error='DISTANCE') -------------------------------------------------------------

def file_skeleton(read, rotations, rewritten):
    """The armature as the file poses it, as a quatcurve.Skeleton; `read`'s arrays changed in place
    for the bones not in `rewritten` (indices). A glTF node inherits all of its parent's transform;
    the exporter writes a bone whose rotation is not its channels' alone (Inherit Rotation off, a
    parent's scale it does not inherit; such samplers are kept as sampled) as its pose relative to
    its parent's, frame by frame. So every bone not rewritten is posed in the file by that fixed
    local transform, offs⁻¹·parent pose⁻¹·pose (Blender's pose of `rotations`), under the parent's pose
    in the file: it becomes a bone that inherits everything, with that transform's rotation, scale
    and location as its channels. Raises GltfError where that transform shears (not a rotation
    times a scale along its axes)."""
    qc = native.require()
    pose = read.skeleton().pose(read.locations, rotations, read.scales)
    inherit_rotation, connected = read.inherit_rotation.copy(), read.connected.copy()
    inherit_scale = list(read.inherit_scale)
    for b, parent in enumerate(read.parents):
        if b in rewritten or parent < 0 or (inherit_rotation[b] and inherit_scale[b] == "FULL"):
            continue
        offset = np.linalg.inv(read.rest[parent]) @ read.rest[b]
        local = np.linalg.inv(offset) @ np.linalg.inv(pose[parent]) @ pose[b]  # (N, 4, 4)
        scale = np.linalg.norm(local[:, :3, :3], axis=1)                       # the columns' lengths
        turn = local[:, :3, :3] / scale[:, None, :]
        shear = np.abs(np.einsum("nji,njk->nik", turn, turn) - np.eye(3)).max()
        if shear > 1e-4:
            raise GltfError("%s/%s: the glTF file poses it with a sheared transform (its parent's non-uniform "
                            "scale), which the distance bound does not model; export with error='ANGLE'"
                            % (read.object.name, read.names[b]))
        rotations[b] = qc.matrix_to_quat(turn)
        read.locations[b] = local[:, :3, 3]
        read.scales[b] = scale
        inherit_rotation[b], connected[b], inherit_scale[b] = True, False, "FULL"
    return qc.Skeleton(read.parents, read.rest, read.lengths, inherit_rotation, connected, inherit_scale)


def reduce_distance(plans, settings, scene):
    """{id(plan): (key frames, keys, error, description)} for every plan, and a DistanceResult per
    armature or object: per armature, every bone's keys chosen by the native
    Skeleton.reduce_slerp so that every bone's virtual vertices (tail, and the points at `shell`
    along its axes) played from the file stay within `distance` of its curve's pose at every frame
    of the sampler and every key there (bones without a rewritten sampler posed as Blender poses
    them); per object, its own three shell points. Raises GltfError as skeleton.py refuses (what
    the bound does not model), for a loop, and where no keys reach the distance."""
    from . import skeleton
    qc = native.require()
    distance, shell = reduce.scene_lengths(settings, scene)
    units = scene.unit_settings
    system, scale_length = units.system, units.scale_length or 1.0
    groups = {}
    for plan in plans:
        obj = plan.target.object
        key = (obj.name_full, plan.target.bone is not None)
        groups.setdefault(key, (obj, plan.target.bone is not None, []))[2].append(plan)
    done, results = {}, []
    for obj, is_armature, group in groups.values():
        for plan in group:
            if plan.loop is not None:
                raise GltfError("%s: loops with the distance bound are not supported yet: its rotation loops (Cycles "
                                "modifiers); export with error='ANGLE'" % plan.target.name)
        span = (min(p.frames[0] for p in group), max(p.frames[-1] for p in group))
        try:
            read = (skeleton.read_armature(obj, [], span=span) if is_armature else
                    skeleton.read_object(obj, span=span, keys_required=False))
        except TargetError as error:
            raise GltfError(str(error)) from None
        index = {name: b for b, name in enumerate(read.names)}
        frames = read.frames
        rotations = np.array([qc.channels_to_quats(v, mode) for mode, v in read.rotations])
        bones = [None] * len(read.names)
        by_bone = {}
        for plan in group:
            b = index[plan.target.bone if is_armature else read.names[0]]
            if is_armature and read.parents[b] >= 0 and not read.inherit_rotation[b]:
                # A glTF node inherits its parent's rotation: rewritten, such a bone's keys would carry
                # its parent's key error in the file, which its own Blender pose (not inheriting the
                # parent's rotation) does not show. Its exporter samples are kept and measured as they are.
                done[id(plan)] = ("kept as sampled: Inherit Rotation off, and a glTF node inherits its parent's "
                                  "rotation, so under the distance bound the file keeps the exporter's pose of it "
                                  "relative to its parent")
                continue
            rotations[b] = plan.sample(frames)
            # Blocking keys: the STEP sampler plays the pose Blender does, so the bone is not reduced.
            bones[b] = plan.slerp_bone() if plan.steps is None else None
            by_bone[b] = plan
        sk = read.skeleton()
        if is_armature:
            sk = file_skeleton(read, rotations, set(by_bone))
        slack = reduce.float32_slack(read, shell)
        if slack >= 0.5 * distance:
            raise GltfError("%s: a distance of %s is below what float32 keeps at this size (%s)" % (
                obj.name, reduce.length_text(distance, system, scale_length),
                reduce.length_text(2 * slack, system, scale_length)))
        try:
            result = sk.reduce_slerp(frames, rotations, read.locations, read.scales, distance - slack, shell, bones)
        except ValueError as error:
            raise GltfError("%s: %s" % (obj.name, error)) from None
        error = result.error
        if error.distance > distance - slack:
            # The tightest keys the search tries (every bone at its smallest angle budget) leave this
            # much: where the rotation turns faster than slerp keys follow (they keep 1/1024 frame
            # apart: keys a hundredth of a frame apart that turn far, say), or float32 at this size.
            where = ("" if error.bone < 0 else " at %s's %s near frame %s" % (
                read.names[error.bone], reduce.VERTEX_NAMES[error.vertex] if error.vertex >= 0 else "pose",
                targets.num(float(frames[error.sample]))))
            raise GltfError("%s: no keys keep every virtual vertex within %s: the tightest still leave %s%s (the "
                            "rotation turns there faster than the file's keys, 1/1024 frame apart at the closest, "
                            "follow, or float32 cannot hold it at this size); export with a larger distance, or "
                            "with error='ANGLE', which writes each sampler with the bound it reaches" % (
                                obj.name, reduce.length_text(distance, system, scale_length),
                                reduce.length_text(error.distance, system, scale_length), where))
        for b, plan in by_bone.items():
            if plan.steps is not None:
                done[id(plan)] = step_keys(plan)
                continue
            keys = result.keys[b]
            how = plan.how + ", angle budget %.4g°" % math.degrees(result.budgets[b])
            if plan.proved_against is not None:
                how += proof_text(keys)
            else:
                how += " at the checked points (between them not proved: %s)" % plan.why
            done[id(plan)] = (keys.key_times, keys.keys.quats, keys.proof.bound + FLOAT32_QUAT, how)
        where = read.names[error.bone] if error.bone >= 0 else "-"
        results.append(DistanceResult(
            obj.name, error.distance, where, float(frames[error.sample]) if error.bone >= 0 else float(frames[0]),
            reduce.VERTEX_NAMES[error.vertex] if error.vertex >= 0 else "-",
            reduce.length_text(error.distance, system, scale_length), reduce.length_text(distance, system, scale_length)))
    return done, results


def rewrite(doc, scene, settings, fps):
    """Replaces the rotation samplers of `doc` in place; returns (the SamplerResults, the
    DistanceResults of error DISTANCE)."""
    mapped = node_targets(doc.json, scene)
    slid = exporter_slides(scene)
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
                planned = plan_sampler(doc, sampler, target, settings, fps, slid)
            except TargetError as e:
                raise GltfError(str(e)) from None
            except ValueError as e:
                raise GltfError("%s: %s" % (target.name, e)) from None
            if isinstance(planned, str):
                results.append(SamplerResult(anim.get("name", ""), name, target.name, count, count, 0.0, planned, False))
                continue
            results.append(SamplerResult(anim.get("name", ""), name, target.name, count, 0, 0.0, planned.how))
            plans.append((sampler, planned, results[-1]))
    distances = []
    if settings.error == "DISTANCE":
        found, distances = reduce_distance([plan for _, plan, _ in plans], settings, scene)
    written = []
    for sampler, plan, result in plans:
        if settings.error == "DISTANCE" and isinstance(found[id(plan)], str):  # kept (reduce_distance)
            result.keys_after, result.curve, result.rewritten = result.keys_before, found[id(plan)], False
            continue
        try:
            key_frames, keys, error, how = found[id(plan)] if settings.error == "DISTANCE" else \
                reduce_sampler(plan, settings)
        except ValueError as e:
            raise GltfError("%s: %s" % (plan.target.name, e)) from None
        times, quats = sampler_keys(plan, key_frames, keys)
        result.keys_after, result.max_error, result.curve = len(times), error, how
        written.append((sampler, times, quats, "STEP" if plan.steps is not None else "LINEAR"))
    plans = written
    # Key times already stored (the exporter's inputs, and ours as they are written): samplers with
    # the same times share one input accessor (still motion keeps its first and last sample).
    inputs = {}
    for anim in doc.json.get("animations", []):
        for sampler in anim["samplers"]:
            try:
                inputs.setdefault(doc.accessor_array(sampler["input"]).astype("<f4").tobytes(), sampler["input"])
            except glb.GlbError:
                pass
    for sampler, times, quats, interpolation in plans:
        sampler["interpolation"] = interpolation
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
    return results, distances


def exporter_fps(scene):
    """The frames per second Blender's glTF exporter writes times with, so that the rewritten rotation
    keys run on the clock of the file's other samplers: render.fps × render.fps_base from Blender 4.1
    (glTF-Blender-IO #2080; the importer reads with it too), render.fps alone before. Neither is the
    scene's own rate fps / fps_base unless fps_base is 1."""
    if bpy.app.version >= (4, 1, 0):
        return scene.render.fps * scene.render.fps_base
    return float(scene.render.fps)


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
    fps = exporter_fps(scene)
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
            results, distances = rewrite(doc, scene, settings, fps)
        glb.write(doc, rewritten)
        os.replace(rewritten, filepath)
    finally:
        for path in (sampled, rewritten):
            if os.path.exists(path):
                os.remove(path)
    return ExportResult(filepath, settings, results, os.path.getsize(filepath), distances)
