"""Shared fixtures for the background tests, in every supported Blender (binary or bpy module).

The add-on is imported from addon/ (with the native module the build copied into it), never from a
venv, so these tests see exactly what a user's Blender sees.
"""

import os
import sys

import bpy
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ADDON_DIR = os.path.join(ROOT, "addon")
SHARED = os.path.join(os.path.dirname(ROOT), "shared")
if ADDON_DIR not in sys.path:
    sys.path.insert(0, ADDON_DIR)

import quatcurve_blender  # noqa: E402


def pytest_report_header(config):
    return "blender %s (%s)" % (bpy.app.version_string, os.environ.get("QUATCURVE_TEST_BLENDER", "?"))


@pytest.fixture(scope="session")
def addon():
    """The add-on package, registered for the whole session."""
    quatcurve_blender.register()
    yield quatcurve_blender
    quatcurve_blender.unregister()


@pytest.fixture
def scene(addon):
    """An empty scene in a fresh file, the add-on registered."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene
