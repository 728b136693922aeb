"""Builds the demo scene from scratch (runs inside Blender, background mode).

    blender --background --factory-startup --python build_scripts/demo_scene.py -- OUT.blend [BVH]

Objects, each showing one way Blender's own rotation interpolation misbehaves:
- "FixedAngle": Euler XYZ keys (0°, 90°, 0°) → (90°, 45°, 90°), LINEAR — the classic fixed-angle
  example: the direct average (45°, 67.5°, 45°) is not the rotation halfway, (90°, 67.5°, 90°) is.
- "Spin": Euler Z keys 0° → 720° — a double spin that a quaternion conversion loses.
- "Hemisphere": quaternion keys where neighbours sit in opposite hemispheres (q vs −q): Blender's
  component-wise interpolation loops the long way round.
- "Mocap": an armature animated from a real motion-capture clip (when the BVH file is present),
  imported with Blender's own BVH importer as quaternion bones.
"""

import builtins
import math
import os
import sys

import bpy


def import_bvh(path, rotate_mode="QUATERNION"):
    """Blender's own BVH importer. Its 3.x version opens files with mode 'rU', which Python 3.11
    rejects: give that module an `open` that drops the 'U' (the importer is otherwise unchanged)."""
    from io_anim_bvh import import_bvh as importer

    def open_text(file, mode="r", *args, **kwargs):
        return builtins.open(file, mode.replace("U", ""), *args, **kwargs)

    importer.open = open_text
    before = set(bpy.data.objects)
    from mathutils import Matrix

    importer.load(bpy.context, path, target="ARMATURE", rotate_mode=rotate_mode, global_matrix=Matrix(),
                  update_scene_fps=False, update_scene_duration=False, report=lambda *a: None)
    created = [o for o in bpy.data.objects if o not in before]
    return next(o for o in created if o.type == "ARMATURE")


def key_euler(obj, frames_and_degrees, interpolation="LINEAR"):
    obj.rotation_mode = "XYZ"
    for frame, degrees in frames_and_degrees:
        obj.rotation_euler = [math.radians(d) for d in degrees]
        obj.keyframe_insert("rotation_euler", frame=frame)
    set_interpolation(obj, interpolation)


def key_quaternion(obj, frames_and_quats, interpolation="LINEAR"):
    obj.rotation_mode = "QUATERNION"
    for frame, q in frames_and_quats:
        obj.rotation_quaternion = q
        obj.keyframe_insert("rotation_quaternion", frame=frame)
    set_interpolation(obj, interpolation)


def set_interpolation(obj, interpolation):
    """Scene building only (not the add-on): the demo's keys are few, so a per-key loop is fine. The
    key points are reached through the RNA path resolver, which works with legacy and slotted actions."""
    anim = obj.animation_data
    action = anim.action
    bags = [action] if bpy.app.version < (4, 4, 0) else [
        strip.channelbag(anim.action_slot) for layer in action.layers for strip in layer.strips]
    for bag in bags:
        for fcurve in bag.fcurves:
            for point in fcurve.keyframe_points:
                point.interpolation = interpolation


def build(out_path, bvh_path=None):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 61

    def empty(name, x):
        obj = bpy.data.objects.new(name, None)
        obj.empty_display_type = "ARROWS"
        obj.location = (x, 0, 0)
        scene.collection.objects.link(obj)
        return obj

    key_euler(empty("FixedAngle", 0), [(1, (0, 90, 0)), (21, (90, 45, 90))])
    key_euler(empty("Spin", 3), [(1, (0, 0, 0)), (31, (0, 0, 360)), (61, (0, 0, 720))])
    s, c = math.sin(math.radians(60)), math.cos(math.radians(60))
    key_quaternion(empty("Hemisphere", 6), [(1, (1, 0, 0, 0)), (21, (c, s, 0, 0)), (41, (-c, 0, -s, 0)),
                                            (61, (0.5, 0.5, 0.5, 0.5))])
    if bvh_path and os.path.exists(bvh_path):
        arm = import_bvh(bvh_path)
        arm.name = "Mocap"
        arm.location = (9, 0, 0)
        arm.scale = (0.05, 0.05, 0.05)
    elif bvh_path:
        print("demo: %s not found, scene built without the motion-capture armature" % bvh_path)
    bpy.ops.wm.save_as_mainfile(filepath=out_path)
    print("demo: wrote %s (%s)" % (out_path, ", ".join(o.name for o in scene.objects)))


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    build(os.path.abspath(args[0]), os.path.abspath(args[1]) if len(args) > 1 else None)
