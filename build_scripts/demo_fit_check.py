"""The demo's fit, measured by Blender: a fresh Blender process (no add-on loaded) opens the fitted
.blend, plays every chosen target at every frame and `subframes` points per frame (scene.frame_set
with the subframe), and compares the rotation Blender builds with the native curve of the method
through the target's animator keys (every rotation key not typed GENERATED — JITTER on 3.4, which
lacks that type). Prints one row per target; an armature is one row (its fitted pose bones taken
together, the worst bone named).

    blender -b --factory-startup --python build_scripts/demo_fit_check.py -- FITTED.blend MODULE_DIR \
        METHOD TOLERANCE SUBFRAMES OBJECT [OBJECT ...]
    python build_scripts/demo_fit_check.py FITTED.blend MODULE_DIR ...              (bpy module)

MODULE_DIR: the folder holding the compiled `quatcurve` module (build/python). Exit status 1 when a
target's error is above the tolerance."""
import math
import sys

import bpy
import numpy as np
from mathutils import Euler, Quaternion

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
blend, module_dir, method, tolerance, subframes, *names = argv
tolerance, subframes = float(tolerance), int(subframes)
sys.path.insert(0, module_dir)
import quatcurve  # noqa: E402  (the native module alone: nothing of the add-on)

assert "quatcurve_blender" not in sys.modules
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
GENERATED = "GENERATED" if bpy.app.version >= (4, 2, 0) else "JITTER"
EULER = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


def rotation_fcurves(obj, path):
    """The F-curves of `path` in what `obj` plays (a legacy action, or the slot's channelbag)."""
    anim = obj.animation_data
    action = anim.action if anim else None
    if action is None:
        return []
    if bpy.app.version >= (4, 4, 0):
        found = []
        for layer in action.layers:
            for strip in layer.strips:
                bag = strip.channelbag(anim.action_slot) if anim.action_slot else None
                found += [f for f in (bag.fcurves if bag else ()) if f.data_path == path]
        return found
    return [f for f in action.fcurves if f.data_path == path]


def animator_keys(owner):
    """(mode, frames, values (K, C), generated key count) of the owner's rotation channels."""
    mode = owner.rotation_mode
    prop = "rotation_quaternion" if mode == "QUATERNION" else "rotation_euler"
    path = owner.path_from_id(prop)
    curves = sorted(rotation_fcurves(owner.id_data, path), key=lambda f: f.array_index)
    if not curves:
        return None
    keys, generated = {}, 0
    for f in curves:
        mine = [(p.co[0], p.co[1]) for p in f.keyframe_points if p.type != GENERATED]
        generated += len(f.keyframe_points) - len(mine)
        keys[f.array_index] = dict(mine)
    frames = sorted(set().union(*keys.values()))
    current = getattr(owner, prop)
    values = np.array([[keys.get(c, {}).get(t, current[c]) for c in range(len(current))] for t in frames])
    return mode, np.array(frames, float), values, generated


def blender_quat(owner):
    if owner.rotation_mode == "QUATERNION":
        return list(Quaternion(owner.rotation_quaternion).normalized())
    return list(Euler(owner.rotation_euler, owner.rotation_mode).to_quaternion())


rows, worst = [], 0.0
scene = bpy.context.scene
for name in names:
    obj = bpy.data.objects[name]
    owners = [pb for pb in obj.pose.bones] if obj.pose is not None else [obj]
    fitted = []
    for owner in owners:
        got = animator_keys(owner)
        if got is None or owner.rotation_mode not in EULER + ("QUATERNION",):
            continue
        mode, frames, values, generated = got
        if len(frames) < 2:
            continue
        if mode == "QUATERNION":
            curve = quatcurve.Curve(frames, values, method)
        else:
            curve = quatcurve.Curve.from_euler(frames, values, order=mode, method=method)
        fitted.append((owner, mode, frames, generated, curve))
    first = min(f[2][0] for f in fitted)
    last = max(f[2][-1] for f in fitted)
    times = np.arange(math.ceil(first * subframes), math.floor(last * subframes) + 1) / subframes
    played = {id(f[0]): [] for f in fitted}
    for t in times:
        whole = math.floor(t)
        scene.frame_set(int(whole), subframe=float(t - whole))
        for f in fitted:
            played[id(f[0])].append(blender_quat(f[0]))
    row_error, row_bone, animator, generated_total = 0.0, "", 0, 0
    for owner, mode, frames, generated, curve in fitted:
        inside = (times >= frames[0]) & (times <= frames[-1])
        got = np.array(played[id(owner)])[inside]
        want = curve.sample(times[inside])
        error = math.degrees(quatcurve.angle_between(got, want).max())
        if error >= row_error:
            row_error, row_bone = error, owner.name
        animator += len(frames)
        generated_total += generated
    modes = sorted({f[1] for f in fitted})
    what = "%d pose bones" % len(fitted) if obj.pose is not None else "object"
    rows.append((name, what, "/".join(modes), animator, generated_total, row_error,
                 "(%s)" % row_bone if obj.pose is not None else "", len(times)))
    worst = max(worst, row_error)

print("Fit (%s, tolerance %g°) measured by Blender %s in a fresh process without the add-on, every frame "
      "and %d subframes, against the native %s curve through the animator keys:"
      % (method, tolerance, bpy.app.version_string, subframes, method))
print("  %-11s %-15s %-10s %9s %10s %10s" % ("target", "what", "mode", "animator", "generated", "max error"))
for name, what, mode, animator, generated, error, bone, samples in rows:
    print("  %-11s %-15s %-10s %9d %10d %9.4f° %s" % (name, what, mode, animator, generated, error, bone))
print("  (animator: key frames per target, summed over bones; generated: inserted keys over all channels)")
if worst > tolerance + 1e-4:
    print("demo_fit_check: error %.4f° above the tolerance %g°" % (worst, tolerance), file=sys.stderr)
    sys.exit(1)
