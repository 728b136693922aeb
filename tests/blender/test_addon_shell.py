"""The add-on registers and unregisters cleanly and imports the native module inside Blender."""

import sys

import bpy

import quatcurve_blender
from quatcurve_blender import native


def test_native_module_imports_inside_blender():
    print("Blender %s, Python %d.%d" % ((bpy.app.version_string,) + sys.version_info[:2]))
    assert native.available(), native.UNAVAILABLE_REASON
    assert native.module.__version__


def test_register_unregister_twice():
    # Other test files may have registered the add-on for their session: leave it as found.
    was_registered = hasattr(bpy.types, "QUATCURVE_PT_view3d")
    if was_registered:
        quatcurve_blender.unregister()
    try:
        for _ in range(2):
            quatcurve_blender.register()
            assert hasattr(bpy.types, "QUATCURVE_PT_view3d")
            assert hasattr(bpy.types, "QUATCURVE_OT_bake") and hasattr(bpy.types, "QUATCURVE_OT_compare")
            quatcurve_blender.unregister()
            assert not hasattr(bpy.types, "QUATCURVE_PT_view3d")
    finally:
        if was_registered:
            quatcurve_blender.register()


def test_missing_module_reason_names_the_python(tmp_path):
    running = "Python %d.%d" % sys.version_info[:2]
    reason = native._diagnose(ImportError("No module named 'quatcurve'"), str(tmp_path))
    assert "missing" in reason and running in reason
    # A build for a Python no Blender runs (3.9), so it is "another Python" in every Blender tested.
    (tmp_path / "quatcurve.cpython-39-x86_64-linux-gnu.so").write_bytes(b"")
    reason = native._diagnose(ImportError("No module named 'quatcurve'"), str(tmp_path))
    assert "built for another Python" in reason and running in reason
