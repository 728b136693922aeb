"""Blender's own evaluation of rotations in a saved .blend, in a fresh process without the add-on.

    blender -b --factory-startup FILE.blend --python evaluate_rotations.py -- REQUEST.json OUT.json
    python evaluate_rotations.py FILE.blend REQUEST.json OUT.json        (bpy module)

REQUEST: {"targets": [[object, bone or null], ...], "times": [frame, ...]}. OUT: {"quats": {name:
[[w, x, y, z], ...]}} — the owner's rotation as Blender builds it from its rotation mode, at each
time (scene.frame_set with the subframe), normalized (axis-angle: from the owner's matrix_basis).
With "matrices": true in the request, OUT also has {"matrices": {name: [[16 floats, row-major], ...]}}:
a pose bone's pose_bone.matrix (armature space), an object's matrix_basis. Nothing of quatcurve is
imported."""
import json
import math
import sys

import bpy
from mathutils import Euler, Quaternion

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
if len(argv) == 3:  # bpy module: the file comes first
    bpy.ops.wm.open_mainfile(filepath=argv[0])
    argv = argv[1:]
request_path, out_path = argv
with open(request_path) as f:
    request = json.load(f)
assert "quatcurve_blender" not in sys.modules, "the add-on must not be loaded"
scene = bpy.context.scene


def bone_of(owner):
    return isinstance(owner, bpy.types.PoseBone)


owners = {}
for obj_name, bone in request["targets"]:
    obj = bpy.data.objects[obj_name]
    owners["%s/%s" % (obj_name, bone) if bone else obj_name] = obj.pose.bones[bone] if bone else obj
out = {name: [] for name in owners}
matrices = {name: [] for name in owners} if request.get("matrices") else None
for t in request["times"]:
    whole = math.floor(t)
    scene.frame_set(int(whole), subframe=float(t - whole))
    for name, owner in owners.items():
        mode = owner.rotation_mode
        if mode == "QUATERNION":
            q = Quaternion(owner.rotation_quaternion).normalized()
        elif mode == "AXIS_ANGLE":
            # Blender's own builder (axis_angle_to_mat3: the axis normalized, a zero axis the
            # identity), through the owner's basis matrix (unit scale in these tests).
            q = owner.matrix_basis.to_3x3().normalized().to_quaternion()
        else:
            q = Euler(owner.rotation_euler, mode).to_quaternion()
        out[name].append(list(q))
        if matrices is not None:
            m = owner.matrix if bone_of(owner) else owner.matrix_basis
            matrices[name].append([v for row in m for v in row])
with open(out_path, "w") as f:
    json.dump({"quats": out, "matrices": matrices, "blender": bpy.app.version_string}, f)
