"""Blender's own evaluation of rotations in a saved .blend, in a Blender process without the add-on.

One file:
    blender -b --factory-startup FILE.blend --python evaluate_rotations.py -- REQUEST.json OUT.json
    python evaluate_rotations.py FILE.blend REQUEST.json OUT.json        (bpy module)
Many files, one process (tests/blender/fresh_blender.py):
    blender -b --factory-startup --python evaluate_rotations.py -- --serve
    python evaluate_rotations.py --serve                                 (bpy module)
  reads one JSON line per file from stdin, {"blend": FILE, "request": REQUEST.json, "out": OUT.json},
  opens FILE (which replaces everything the previous file held: objects, actions, the depsgraph),
  evaluates it and prints a line "quatcurve-evaluate: ok" or "quatcurve-evaluate: error …"; it leaves
  at the end of its input. The add-on is never imported in this process, so every file is played by
  Blender alone, as in a process started for it.

REQUEST: {"targets": [[object, bone or null], ...], "times": [frame, ...]}. OUT: {"quats": {name:
[[w, x, y, z], ...]}} — the owner's rotation as Blender builds it from its rotation mode, at each
time (scene.frame_set with the subframe), normalized (axis-angle: from the owner's matrix_basis).
With "matrices": true in the request, OUT also has {"matrices": {name: [[16 floats, row-major], ...]}}:
a pose bone's pose_bone.matrix (armature space), an object's matrix_basis. Nothing of quatcurve is
imported."""
import json
import math
import os
import sys
import traceback

import bpy
from mathutils import Euler, Quaternion

DONE = "quatcurve-evaluate:"


def evaluate(request_path, out_path):
    with open(request_path) as f:
        request = json.load(f)
    assert "quatcurve_blender" not in sys.modules, "the add-on must not be loaded"
    scene = bpy.context.scene
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
                m = owner.matrix if isinstance(owner, bpy.types.PoseBone) else owner.matrix_basis
                matrices[name].append([v for row in m for v in row])
    with open(out_path, "w") as f:
        json.dump({"quats": out, "matrices": matrices, "blender": bpy.app.version_string}, f)


def serve():
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            job = json.loads(line)
            bpy.ops.wm.open_mainfile(filepath=job["blend"])
            evaluate(job["request"], job["out"])
            status = "ok"
        except Exception:
            status = "error " + traceback.format_exc().replace("\n", " | ")
        print(DONE, status, flush=True)


argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
if argv == ["--serve"]:
    serve()
    sys.stdout.flush()
    os._exit(0)  # the input is done; a bpy module can hang in its exit-time destructors
else:
    if len(argv) == 3:  # bpy module: the file comes first
        bpy.ops.wm.open_mainfile(filepath=argv[0])
        argv = argv[1:]
    evaluate(*argv)
