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


# Checks marked `per_kind` exercise a path that is the same in every Blender of one kind (the
# executable, or the bpy module): the command line's and the batch's parsing, scheduling, crash
# recovery and Slurm, wrapped around tasks that every pass checks in-process. They run in the
# executable's pass and in one bpy module's pass; CTest tells the other passes so with
# QUATCURVE_TEST_PER_KIND=0 and names where they run. Run by hand, every pass runs them.
def pytest_configure(config):
    config.addinivalue_line("markers", "per_kind: runs in one pass per kind of Blender (executable, bpy module)")


def pytest_collection_modifyitems(config, items):
    if os.environ.get("QUATCURVE_TEST_PER_KIND", "1") != "0":
        return
    where = os.environ.get("QUATCURVE_TEST_PER_KIND_PASSES", "another pass")
    skip = pytest.mark.skip(reason="the same path in every Blender of this kind: checked in the %s pass" % where)
    for item in items:
        if item.get_closest_marker("per_kind"):
            item.add_marker(skip)


def pytest_sessionfinish(session, exitstatus):
    import fresh_blender
    fresh_blender.stop()


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
