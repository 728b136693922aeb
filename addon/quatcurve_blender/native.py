"""Loads the compiled `quatcurve` module, or records why it could not be loaded.

The add-on must register even when the module is missing or was built for another Python: the
panel then shows `UNAVAILABLE_REASON` and every operator refuses with it (see `require`).
Search order: the module copied into this package by the build (legacy add-on, development), then a
top-level `quatcurve` (the platform wheel of a Blender 4.2+ extension, or a venv).
"""

import glob
import os
import sys

module = None
UNAVAILABLE_REASON = ""


def _python_tag():
    return "cpython-%d%d" % sys.version_info[:2]


def _diagnose(error, here=os.path.dirname(os.path.abspath(__file__))):
    built = sorted(os.path.basename(p) for p in glob.glob(os.path.join(here, "quatcurve*.so")) +
                   glob.glob(os.path.join(here, "quatcurve*.pyd")))
    running = "Python %d.%d" % sys.version_info[:2]
    if built and not any(_python_tag() in name for name in built):
        return ("the compiled quatcurve module (%s) was built for another Python; this Blender runs %s: "
                "rebuild it for %s (see docs/packaging.md, 'Building for another Blender')"
                % (", ".join(built), running, running))
    if built:
        return "the compiled quatcurve module (%s) failed to load: %s" % (", ".join(built), error)
    return ("the compiled quatcurve module is missing (%s): run build_scripts/test.sh or install a "
            "packaged release built for %s" % (error, running))


def _load():
    global module, UNAVAILABLE_REASON
    try:
        from . import quatcurve as found
    except ImportError as first:
        try:
            import quatcurve as found
        except ImportError:
            module, UNAVAILABLE_REASON = None, _diagnose(first)
            return
    module, UNAVAILABLE_REASON = found, ""


_load()


def available():
    return module is not None


def require():
    """The native module; raises RuntimeError carrying the reason when it is unavailable."""
    if module is None:
        raise RuntimeError("quatcurve is unavailable: " + UNAVAILABLE_REASON)
    return module
