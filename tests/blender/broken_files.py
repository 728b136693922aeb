"""Input files that Blender cannot read, as a library or a farm meets them: a BVH clip cut in the middle
of its MOTION section, binary FBX and glTF files cut in half, a glTF whose BIN chunk lost its data, a
text file named .blend, a .blend cut in half. Each is written from a whole file made here (Blender's
own exporters), so the damage is the only thing wrong with it.

    made = broken_files.make(folder)    # {kind: path}: kinds below
    broken_files.write_bvh(path)         # the same clip whole
"""

import math
import os
import struct

import bpy

# Two joints, 9 channels per frame row; the HIERARCHY and the MOTION header take 18 lines.
BVH_HEAD = """HIERARCHY
ROOT Hips
{
  OFFSET 0.0 0.0 0.0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0.0 1.0 0.0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0.0 1.0 0.0
    }
  }
}
MOTION
Frames: 24
Frame Time: 0.041667
"""
BVH_ROWS = ["0 0 0 %g %g %g %g %g %g" % (3 * i, 40 * math.sin(i / 4), i, 0, 2 * i, 30 * math.cos(i / 5))
            for i in range(24)]
# The cut clip: 10 whole rows (lines 19-28), then the 11th cut after 4 of its 9 values (line 29).
CUT_BVH_LINE, CUT_BVH_ROWS = 29, 10


def _whole_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = bpy.data.objects.new("Spin", None)
    bpy.context.scene.collection.objects.link(obj)
    for frame, angle in ((1, 0.0), (11, 1.0), (21, 2.5)):
        obj.rotation_euler = (angle, angle / 2, 0.0)
        obj.keyframe_insert("rotation_euler", frame=frame)


def _cut(path):
    """Keeps the first half of the file."""
    with open(path, "rb") as f:
        data = f.read()
    with open(path, "wb") as f:
        f.write(data[:len(data) // 2])


def write_bvh(path, rows=24):
    """The clip with its first `rows` frame rows (24: whole)."""
    with open(path, "w") as f:
        f.write(BVH_HEAD + "".join(row + "\n" for row in BVH_ROWS[:rows]))


def make(folder):
    """Writes the broken files into `folder`; returns {kind: path}:
    bvh     walk.bvh: 10 whole frame rows of 24, the 11th cut after 4 of its 9 values
    fbx     roll.fbx: the first half of a binary FBX
    glb     spin.glb: the first half of a .glb
    glb_bin hollow.glb: a .glb whose BIN chunk was cut to 8 bytes (the chunk and file lengths made
            to agree again, so only the buffer is short)
    text    notes.blend: a text file
    blend   shot.blend: the first half of a .blend, as this Blender saves it (compressed or not)
    The output names differ (batch saves each as <name>.blend)."""
    os.makedirs(folder, exist_ok=True)
    made = {kind: os.path.join(folder, name) for kind, name in (
        ("bvh", "walk.bvh"), ("fbx", "roll.fbx"), ("glb", "spin.glb"), ("glb_bin", "hollow.glb"),
        ("text", "notes.blend"), ("blend", "shot.blend"))}
    with open(made["bvh"], "w") as f:
        f.write(BVH_HEAD + "".join(row + "\n" for row in BVH_ROWS[:CUT_BVH_ROWS])
                + " ".join(BVH_ROWS[CUT_BVH_ROWS].split()[:4]))
    _whole_scene()
    bpy.ops.export_scene.fbx(filepath=made["fbx"], bake_anim=True)
    bpy.ops.export_scene.gltf(filepath=made["glb"], export_format="GLB")
    bpy.ops.wm.save_as_mainfile(filepath=made["blend"], copy=True)
    with open(made["glb"], "rb") as f:
        glb = f.read()
    json_length = struct.unpack_from("<I", glb, 12)[0]
    chunks = glb[12:20 + json_length] + struct.pack("<II", 8, 0x004E4942) + bytes(8)
    with open(made["glb_bin"], "wb") as f:
        f.write(glb[:8] + struct.pack("<I", 12 + len(chunks)) + chunks)
    for kind in ("fbx", "glb", "blend"):
        _cut(made[kind])
    with open(made["text"], "w") as f:
        f.write("shot notes: this was never a .blend\n")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return made
