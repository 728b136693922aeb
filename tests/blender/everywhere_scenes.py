"""Scenes and checks of test_everywhere.py (support code, not a test module): the fit tests' scene
types, built once per case and method in one file, and the measurement of Blender's playback against
a reference at every check time.

A scene is a list of Owners — objects, or pose bones of one rig — each keyed in its own rotation
mode with Blender's keyframe_insert. build(scene, suffix) makes one copy of a scene (object names
and the rig's name carry the suffix, e.g. "XYZ.SQUAD"), so every method of a case lives side by side
in one .blend and one fresh Blender process evaluates them all (test_fit.fresh_blender_quats).
"""

import math
from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Euler, Quaternion

from bake_helpers import add_empty, add_rig, angles_between, key
from quatcurve_blender import fcurves, fit, targets

FLOAT32_SLACK = 1e-4  # degrees: what every fit test adds to its tolerance (keys and handles are float32)
PER_FRAME = 64        # check points per frame (powers of two: exact frame times in float32)
RANDOM_TIMES = 200    # random check times over the scene's range, on a 2^-16 frame grid (exact in float32)
SEED = 27


@dataclass(frozen=True)
class Owner:
    """One keyed rotation owner of a scene. label: its name in the scene (an object's name without
    the suffix, or a bone's name); mode: its rotation mode; keys: ((frame, channel values), …) as
    keyed — radians for angles, quaternions (w, x, y, z) with the signs as stored; interpolation of
    the keys; bone: a pose bone of the scene's rig (else an object)."""
    label: str
    mode: str
    keys: tuple
    interpolation: str = "BEZIER"
    bone: bool = False


def euler_keys(order, keys_deg):
    """Keys given as the angles about the first, middle and last axis of `order` (degrees) → channel
    values (x, y, z) in radians: the same angles by position in every order, so gimbal lock is where
    the middle angle is ±90° (XYZ: the channels as given)."""
    out = []
    for frame, angles in keys_deg:
        channels = [0.0, 0.0, 0.0]
        for position, axis in enumerate(order):
            channels["XYZ".index(axis)] = math.radians(angles[position])
        out.append((frame, tuple(channels)))
    return tuple(out)


def axis_angle_keys(keys_deg):
    """(frame, (angle in degrees, x, y, z)) → (frame, (angle in radians, x, y, z))."""
    return tuple((f, (math.radians(v[0]),) + tuple(v[1:])) for f, v in keys_deg)


def quaternion_keys(keys_axis_deg):
    """(frame, (axis, degrees)) → (frame, quaternion) as mathutils builds it (a turn over 180° gives
    w < 0: neighbours in opposite hemispheres, as an importer stores them)."""
    return tuple((f, tuple(Quaternion(axis, math.radians(deg)))) for f, (axis, deg) in keys_axis_deg)


# (a) The gimbal-lock example — (0°, 90°, 0°) at frame 1, (90°, 45°, 90°) at frame 4 — then
# spins beyond 180° and 360° and a second key at the lock (middle angle −90°) inside the range.
GIMBAL_SPIN = ((1, (0, 90, 0)), (4, (90, 45, 90)), (12, (30, 10, 200)), (20, (-40, -90, 250)),
               (28, (0, 40, 500)), (40, (10, 0, 405)), (44, (0, 20, 380)))
# (b) Quaternion keys whose stored signs flip between neighbours: every pair but 30→31 lies in
# opposite hemispheres as stored, and 31→36 is one rotation stored negated (a hold).
QUAT_FLIPS = ((1, (1.0, 0.0, 0.0, 0.0)), (5, (-0.7071, -0.7071, 0.0, 0.0)), (6, (0.5, 0.5, 0.5, 0.5)),
              (14, (-0.6, 0.0, -0.8, 0.0)), (30, (-0.2, 0.1, 0.9, -0.38)), (31, (0.1, 0.2, 0.9, -0.37)),
              (36, (-0.1, -0.2, -0.9, 0.37)))
# (c) Axis-angle (degrees, axis): from the rest pose a spin of 400° about a tilted non-unit axis, 300°
# more about it, then the axis changing while the angle turns back (test_fit's keys).
AXIS_ANGLE_SPINS = ((1, (0, 0, 0, 2)), (9, (400, 0, 0.3, 1)), (20, (700, 0, 0.3, 1)), (26, (680, 1, 0.2, 0.4)),
                    (40, (600, 0.5, -0.5, 0.7)))
BONE_AXIS_ANGLE = ((1, (30, 1, 0, 0)), (8, (300, 1, 0.1, 0)), (20, (250, 0, 1, 0)), (30, (100, 0, 1, 0.2)))
# (d) A rig's controls in Rigify's modes: quaternion, YXZ (shoulders), ZXY (tweaks, a key at the lock).
RIG_EULER = ((1, (0, 0, 0)), (15, (80, -40, 30)), (35, (-60, 70, 120)), (50, (20, 10, -90)))
RIG_EULER_LOCK = ((1, (0, 0, 0)), (15, (30, -90, -40)), (35, (-60, 70, 120)), (50, (20, 10, -90)))
# (e) What Blender's glTF importer writes for sparse LINEAR rotation samplers: LINEAR quaternion keys
# 100°–300° of turn apart, each key's sign as built (test_fit_inputs' keys).
GLTF_OBJ = ((1, ((1, 0, 0), 0)), (11, ((0, 0, 1), 120)), (31, ((1, 1, 0), 240)), (41, ((0, 1, 1), 100)),
            (61, ((1, 0, 1), 300)))
GLTF_BONE = ((1, ((1, 0, 0), 10)), (21, ((0, 1, 0), 130)), (41, ((1, 0, 1), 250)), (51, ((0, 1, 1), 120)),
             (71, ((1, 1, 1), 0)))

SCENES = {
    "euler": tuple(Owner(order, order, euler_keys(order, GIMBAL_SPIN)) for order in ("XYZ", "YXZ", "ZXY")),
    "quaternion": (Owner("Flips", "QUATERNION", QUAT_FLIPS),),
    "axis_angle": (Owner("Axis", "AXIS_ANGLE", axis_angle_keys(AXIS_ANGLE_SPINS)),),
    "rig": (Owner("Q", "QUATERNION", QUAT_FLIPS[:5], bone=True),
            Owner("Shoulder", "YXZ", euler_keys("YXZ", RIG_EULER), bone=True),
            Owner("Tweak", "ZXY", euler_keys("ZXY", RIG_EULER_LOCK), bone=True),
            Owner("A", "AXIS_ANGLE", axis_angle_keys(BONE_AXIS_ANGLE), bone=True)),
    "gltf": (Owner("GltfObj", "QUATERNION", quaternion_keys(GLTF_OBJ), "LINEAR"),
             Owner("GltfNode", "QUATERNION", quaternion_keys(GLTF_BONE), "LINEAR")),
}


def dense_clip(frames=120):
    """Per-frame LINEAR keys of a smooth motion (what a bake or a capture leaves, what reduce is for):
    a quaternion clip whose stored sign flips on every 7th frame, and an XYZ clip that also spins
    540° about Z."""
    f = np.arange(1, frames + 1, dtype=np.float64)
    angles = np.column_stack([50 * np.sin(f / 9.0), 35 * np.sin(f / 13.0 + 1), 60 * np.sin(f / 11.0 + 2)])
    quats = [tuple(Euler(np.radians(a), "XYZ").to_quaternion()) for a in angles]
    quats = [tuple(-c for c in q) if k % 7 == 6 else q for k, q in enumerate(quats)]
    spin = angles + np.column_stack([np.zeros(frames), np.zeros(frames), 540 * (f - 1) / (frames - 1)])
    return (Owner("DenseQuat", "QUATERNION", tuple(zip(f.tolist(), quats)), "LINEAR"),
            Owner("DenseXYZ", "XYZ", tuple(zip(f.tolist(), map(tuple, np.radians(spin)))), "LINEAR"))


# Scenes only reduce checks: dense keys.
REDUCE_SCENES = {"dense": dense_clip()}


@dataclass(eq=False)
class Built:
    """One owner of a built scene copy: its spec, its targets.Target, its evaluation name (what
    fresh_blender_quats returns it under) and request entry."""
    spec: Owner
    target: targets.Target

    @property
    def name(self):
        return self.target.name

    @property
    def request(self):
        return [self.target.object.name, self.target.bone]

    @property
    def first(self):
        return float(self.spec.keys[0][0])

    @property
    def last(self):
        return float(self.spec.keys[-1][0])


def rotation_prop(mode):
    return fcurves.rotation_property(mode)[0]


def build(scene, suffix, only=None):
    """One copy of SCENES[scene] (or REDUCE_SCENES[scene]), only the owners labelled in `only` when
    given: objects '<label>.<suffix>', bones in a rig '<scene>Rig.<suffix>' (a chain, each bone the
    child of the one before). Returns [Built] in the scene's order."""
    specs = [s for s in SCENES.get(scene) or REDUCE_SCENES[scene] if only is None or s.label in only]
    bones = [s.label for s in specs if s.bone]
    rig = None
    if bones:
        rig = add_rig("%sRig.%s" % (scene, suffix), bones=tuple(bones))
        bpy.ops.object.mode_set(mode="EDIT")
        edit = rig.data.edit_bones
        for parent, child in zip(bones, bones[1:]):
            edit[child].parent = edit[parent]
        bpy.ops.object.mode_set(mode="OBJECT")
    out = []
    for spec in specs:
        if spec.bone:
            owner = rig.pose.bones[spec.label]
            owner.rotation_mode = spec.mode
            target = targets.Target(rig, spec.label)
        else:
            owner = add_empty("%s.%s" % (spec.label, suffix), spec.mode)
            target = targets.Target(owner)
        key(owner, rotation_prop(spec.mode), spec.keys, interpolation=spec.interpolation)
        out.append(Built(spec, target))
    bpy.context.view_layer.update()
    return out


def check_times(first, last, per_frame=PER_FRAME, randoms=RANDOM_TIMES, seed=SEED):
    """Every 1/per_frame frame from `first` to `last` and `randoms` random times between them (a
    fixed seed), sorted. Every time is exact in float32 (Blender's scene time) for frames below 128."""
    grid = np.arange(math.ceil(first * per_frame), math.floor(last * per_frame) + 1) / per_frame
    rng = np.random.default_rng(seed)
    extra = np.round(rng.uniform(first, last, randoms) * 65536.0) / 65536.0
    return np.unique(np.r_[grid, extra])


def reference_curve(keys, method, **per_key):
    """The method's native curve through AnimatorKeys `keys` (targets.build_curve, the fit's default
    options, per-key ease/turns as given): what Blender must play."""
    options = fit.curve_options(fit.FitSettings(method=method), **per_key)
    return targets.build_curve(keys.mode, keys.frames, keys.values, method, keys.name, **options)


@dataclass
class Row:
    """The largest deviation of one owner in one case: case ('fit', 'live', …), scene, method, owner
    label, degrees, the frame where it is, the bound it is held to and a note (generated keys,
    what was refused)."""
    case: str
    scene: str
    method: str
    owner: str
    degrees: float
    frame: float
    bound: float
    note: str = ""

    @property
    def failed(self):
        return not (self.degrees <= self.bound + FLOAT32_SLACK)

    def text(self):
        where = "at frame %.6g" % self.frame if math.isfinite(self.frame) else ""
        return "%s %s %s %s: %.4f° %s (bound %g°)%s" % (
            self.case, self.scene, self.method, self.owner, self.degrees, where, self.bound,
            " — " + self.note if self.note else "")


def deviation(case, scene, method, owner, got, want, times, bound, note="", mask=None):
    """Row of the largest angle (degrees) between Blender's quaternions `got` and the reference
    `want` at `times` (only where `mask` is set)."""
    err = np.degrees(angles_between(got, want))
    if mask is not None:
        err = np.where(mask, err, 0.0)
    k = int(err.argmax())
    return Row(case, scene, method, owner, float(err[k]), float(times[k]), bound, note)


def refused(case, scene, method, owner, bound, error):
    """Row of an operation that was refused or failed: it fails, naming the message."""
    return Row(case, scene, method, owner, math.inf, math.nan, bound, "%s: %s" % (type(error).__name__, error))


def table(rows):
    """The rows as a table: case, scene, owner, then one column per method (largest degrees)."""
    methods = list(dict.fromkeys(r.method for r in rows))
    keys = list(dict.fromkeys((r.case, r.scene, r.owner) for r in rows))
    cell = {(r.case, r.scene, r.owner, r.method): r for r in rows}
    lines = ["%-8s %-11s %-10s " % ("case", "scene", "owner") + " ".join("%12s" % m for m in methods)]
    for case, scene, owner in keys:
        cells = []
        for m in methods:
            r = cell.get((case, scene, owner, m))
            cells.append("%12s" % ("" if r is None else "refused" if math.isinf(r.degrees) else
                                   "%.4f%s" % (r.degrees, "!" if r.failed else "")))
        lines.append("%-8s %-11s %-10s " % (case, scene, owner) + " ".join(cells))
    return "\n".join(lines)


def verdict(rows, title):
    """Prints the table; returns the failure message (empty when every row holds its bound)."""
    print("\n[everywhere] %s (Blender %s), largest deviation in degrees, ! above the bound:\n%s"
          % (title, bpy.app.version_string, table(rows)))
    failed = [r for r in rows if r.failed]
    if not failed:
        return ""
    return "%d of %d cases above the bound:\n  %s" % (len(failed), len(rows), "\n  ".join(r.text() for r in failed))
