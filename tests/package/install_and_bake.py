"""Installs a packaged QuatCurve into a clean Blender user directory, enables it and bakes once.

Runs inside a Blender (the binary with `--python FILE -- ZIP`, or a bpy venv's python `FILE ZIP`);
the caller points BLENDER_USER_SCRIPTS/BLENDER_USER_CONFIG (3.4) or BLENDER_USER_RESOURCES (4.2+)
at an empty folder. Blender ≥ 4.2 installs the extension zip (module from its platform wheel),
older ones the legacy add-on zip. Exits non-zero with a reason on any failure.
"""

import math
import os
import sys

import bpy  # first: addon_utils needs bpy initialized (bpy module builds)

import addon_utils  # noqa: E402


def fail(message):
    print("FAILED:", message)
    sys.stdout.flush()
    sys.exit(1)


package = sys.argv[-1]
print("Blender %s installing %s" % (bpy.app.version_string, os.path.basename(package)))
if bpy.app.version >= (4, 2, 0):
    result = bpy.ops.extensions.package_install_files(filepath=package, repo="user_default",
                                                      enable_on_install=True)
    name = "bl_ext.user_default.quatcurve_blender"
else:
    result = bpy.ops.preferences.addon_install(filepath=package)
    addon_utils.enable("quatcurve_blender", default_set=True)
    name = "quatcurve_blender"
if result != {"FINISHED"}:
    fail("install returned %s" % result)
addon = sys.modules.get(name)
if addon is None:
    fail("%s is not loaded after install" % name)
source_tree = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "addon")
if os.path.abspath(addon.__file__).startswith(source_tree + os.sep):
    fail("the add-on was loaded from the source tree, not the installed package: %s" % addon.__file__)
native = sys.modules[name + ".native"]
if not native.available():
    fail(native.UNAVAILABLE_REASON)
print("native module:", native.module.__file__)

# Bake once: an object turning 150° about Z over 10 frames, two quaternion keys, SLERP.
bpy.ops.object.empty_add()
obj = bpy.context.active_object
obj.rotation_mode = "QUATERNION"
obj.rotation_quaternion = (1, 0, 0, 0)
obj.keyframe_insert("rotation_quaternion", frame=1)
obj.rotation_quaternion = (math.cos(math.radians(75)), 0, 0, math.sin(math.radians(75)))
obj.keyframe_insert("rotation_quaternion", frame=11)
if not hasattr(bpy.types, "QUATCURVE_OT_bake"):
    fail("the bake operator is not registered")
result = bpy.ops.quatcurve.bake(method="SLERP", rotation_mode="QUATERNION")
if result != {"FINISHED"}:
    fail("bake returned %s" % result)
bpy.context.scene.frame_set(6)
q = obj.rotation_quaternion
angle = math.degrees(2 * math.atan2(math.hypot(q.x, q.y, q.z), q.w))
if abs(angle - 75.0) > 1e-3:
    fail("baked SLERP midpoint turns %.4f°, expected 75°" % angle)
print("baked: SLERP midpoint %.4f° (expected 75°)" % angle)
print("1 passed, 0 failed")
