"""Installs a packaged QuatCurve into a clean Blender user directory, enables it, bakes once and fits once.

Runs inside a Blender (the binary with `--python FILE -- ZIP`, or a bpy venv's python `FILE ZIP`);
the caller points BLENDER_USER_SCRIPTS/BLENDER_USER_CONFIG (3.4) or BLENDER_USER_RESOURCES (4.2+)
at an empty folder. Blender ≥ 4.2 installs the extension zip (module from its platform wheel),
older ones the legacy add-on zip. The bake and the fit are checked against the installed native
module's own curve, measured with its `angle_between`. Exits non-zero with a reason on any failure.
"""

import math
import os
import sys

import numpy as np
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
qc = native.module
print("native module:", qc.__file__)
if not hasattr(bpy.types, "QUATCURVE_OT_bake") or not hasattr(bpy.types, "QUATCURVE_OT_fit"):
    fail("the bake and fit operators are not registered")
scene = bpy.context.scene


def select_only(obj):
    for other in bpy.context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def add_quaternion_empty(name, keys):
    bpy.ops.object.empty_add()
    obj = bpy.context.active_object
    obj.name = name
    obj.rotation_mode = "QUATERNION"
    for frame, q in keys:
        obj.rotation_quaternion = q
        obj.keyframe_insert("rotation_quaternion", frame=frame)
    select_only(obj)
    return obj


def played(obj, times):
    """Blender's own evaluation of the object's rotation at (sub)frame times."""
    out = []
    for t in times:
        scene.frame_set(int(math.floor(t)), subframe=float(t - math.floor(t)))
        out.append(tuple(obj.rotation_quaternion))
    return np.array(out)


# Bake once: an object turning 150° about Z over 10 frames, two quaternion keys, SLERP.
baked = add_quaternion_empty("Baked", [(1, (1, 0, 0, 0)), (11, (math.cos(math.radians(75)), 0, 0,
                                                                 math.sin(math.radians(75))))])
result = bpy.ops.quatcurve.bake(method="SLERP", rotation_mode="QUATERNION")
if result != {"FINISHED"}:
    fail("bake returned %s" % result)
angle = math.degrees(qc.angle_between(played(baked, [6.0])[0], (1.0, 0.0, 0.0, 0.0)))
if abs(angle - 75.0) > 1e-3:
    fail("baked SLERP midpoint turns %.4f°, expected 75°" % angle)
print("baked: SLERP midpoint %.4f° (expected 75°)" % angle)

# Fit once: the animator's four quaternion keys get handles and generated keys so that Blender plays
# SQUAD; its playback at every frame and 4 subframes must follow the native SQUAD curve within the
# tolerance.
TOL = 0.05  # degrees
KEYS = [(1, (1.0, 0.0, 0.0, 0.0)), (8, (0.7071, 0.7071, 0.0, 0.0)), (15, (0.5, 0.5, 0.5, 0.5)),
        (27, (0.2, -0.1, 0.9, 0.38))]
fitted = add_quaternion_empty("Fitted", KEYS)
result = bpy.ops.quatcurve.fit(method="SQUAD", tolerance=TOL)
if result != {"FINISHED"}:
    fail("fit returned %s" % result)
fcurves, fit = sys.modules[name + ".fcurves"], sys.modules[name + ".fit"]
types = [fcurves.read_key_types(c) for c in fcurves.Channels.of(fitted).find_all("rotation_quaternion", 4)]
generated = sum(int((t == fit.KEY_TYPE_GENERATED).sum()) for t in types)
times = np.arange(1 * 4, 27 * 4 + 1) / 4.0
want = qc.Curve([f for f, _ in KEYS], [q for _, q in KEYS], "SQUAD").sample(times)
err = np.degrees(qc.angle_between(played(fitted, times), want))
if not err.max() <= TOL + 1e-4:
    fail("fitted SQUAD plays %.5f° from the native curve at frame %s (tolerance %g°)"
         % (err.max(), times[err.argmax()], TOL))
print("fitted: SQUAD played by Blender within %.5f° of the native curve (tolerance %g°, %d samples, "
      "%d generated keys)" % (err.max(), TOL, len(times), generated))
print("2 passed, 0 failed")
