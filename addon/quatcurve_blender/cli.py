"""Baking, fitting, key reduction, rotation-mode conversion and glTF export from the command line:
bake (and optionally compare), fit (`--fit`), reduce (`--reduce`), clean (`--clean`), convert (`--convert MODE`) the
rotations in a .blend file, or export it (`--gltf OUT.glb`), without Blender's UI. Many files at
once: batch.py runs the same operations.

    blender --background --python addon/quatcurve_blender/cli.py -- [options] IN.blend
    blender --background IN.blend --python addon/quatcurve_blender/cli.py -- [options]
    PYTHONPATH=addon python -m quatcurve_blender.cli [options] IN.blend     (a Python with the bpy module)

IN.blend may also be a .bvh, .fbx, .glb or .gltf file, imported into an empty scene with Blender's
importer as batch.py does (inputs.read); an unreadable input is refused with the exception its
reader raised and the likely cause ("the file ends early at line N: …").

Exit status: 0 success; 2 bad arguments (unknown option, method, object or bone, bad frame range,
missing or unreadable input, output that cannot be written); 1 failure (the bake, the comparison or the save
failed). Every error is one line on stderr, `quatcurve: error: <reason>`, without a traceback
(QUATCURVE_DEBUG=1 adds the traceback of unexpected errors). Nothing is saved unless everything
succeeded. IN.blend is only written with --in-place; the output is saved to a temporary file in the
same folder and renamed over the target, so it is either complete or untouched.

This module parses arguments and selects targets by name or glob pattern; the work is done by the
functions the operators call (bake.bake, compare.compare / save_plots / write_report, fit.fit,
reduce.reduce, clean.clean, convert.convert, gltf.export), each wrapped in a Task (BakeTask, FitTask,
ReduceTask, CleanTask, ConvertTask, GltfTask) that batch.py reuses.

When Blender runs this file as a script (`--python cli.py`) it is not inside its package: the
add-on's parent folder is put on sys.path and the package is imported (and registered) by name.
A missing or unreadable IN.blend given *before* `--python` is refused by Blender itself (exit status
1, before this script runs); given after `--`, it is this script's exit status 2.
"""

import argparse
import contextlib
import fnmatch
import math
import os
import sys
import tempfile
import time
import traceback
import uuid

if __package__:
    from . import (bake, bake_ops, clean, compare, compare_ops, convert, fit, fit_ops, gltf, inputs, methods, native,
                   reduce, targets)
    addon = sys.modules[__package__]
else:  # `blender --python cli.py` (or `python cli.py`): a script outside its package
    _here = os.path.dirname(os.path.abspath(__file__))
    # `python cli.py` puts this folder first on sys.path, where the add-on's modules would shadow
    # top-level names: import them only through the package, from the folder above.
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != _here]
    sys.path.insert(0, os.path.dirname(_here))
    import quatcurve_blender as addon
    from quatcurve_blender import (bake, bake_ops, clean, compare, compare_ops, convert, fit, fit_ops, gltf, inputs,
                                   methods, native, reduce, targets)

import bpy

PROG = "quatcurve_blender.cli"
EXIT_OK, EXIT_FAILURE, EXIT_USAGE = 0, 1, 2


class UsageError(Exception):
    """A bad argument (exit status 2); the message names it."""


class Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(message)


USAGE_EPILOG = """\
exit status: 0 success, 2 bad arguments, 1 failure (one line on stderr: "quatcurve: error: ...").

examples:
  blender -b --python addon/quatcurve_blender/cli.py -- --method SQUAD --output out.blend in.blend
  blender -b in.blend --python addon/quatcurve_blender/cli.py -- --objects 'Rig' --bones 'Left*' \\
      --method TCB --tension 0.5 --rotation-mode QUATERNION --in-place
  PYTHONPATH=addon python -m quatcurve_blender.cli --compare --report out/report.json \\
      --output out/baked.blend in.blend
  blender -b --python addon/quatcurve_blender/cli.py -- --fit --method SQUAD --tolerance 0.01 \\
      --objects 'Rig' --output fitted.blend in.blend
  blender -b --python addon/quatcurve_blender/cli.py -- --reduce --tolerance 0.1 --output reduced.blend in.blend
  blender -b --python addon/quatcurve_blender/cli.py -- --convert QUATERNION --all-actions \\
      --objects 'Rig' --output quaternions.blend in.blend
  blender -b --python addon/quatcurve_blender/cli.py -- --gltf out.glb --tolerance 0.1 fitted.blend
"""


def build_parser():
    p = Parser(prog=PROG, formatter_class=argparse.RawDescriptionHelpFormatter, epilog=USAGE_EPILOG,
               description="Bake the rotation animation of objects and pose bones in a .blend file with an\n"
                           "orientation-curve method (the quatcurve.bake operator without the UI), optionally\n"
                           "comparing the methods first (the quatcurve.compare operator); or, with --fit,\n"
                           "shape their own rotation keys so that Blender plays the method (the\n"
                           "quatcurve.fit operator); or, with --reduce, keep as few of their keys as a\n"
                           "tolerance allows (the quatcurve.reduce operator); or, with --convert MODE, change\n"
                           "their rotation mode keeping the motion (the quatcurve.convert operator); or, with\n"
                           "--gltf, export the scene to binary glTF with few rotation keys that play each\n"
                           "target's curve (the quatcurve.export_gltf operator).")
    p.add_argument("input", nargs="?", metavar="IN.blend",
                   help="the file to bake (may be omitted when Blender was started with it: "
                        "blender -b IN.blend --python cli.py -- ...); or a .bvh, .fbx, .glb or .gltf file, "
                        "imported into an empty scene with Blender's importer (then --output is required)")
    add_task_arguments(p)
    g = p.add_argument_group("output", "One of them is required.")
    g.add_argument("--output", metavar="OUT.blend", help="the baked (fitted) file (IN.blend is not changed)")
    g.add_argument("--in-place", action="store_true", help="overwrite IN.blend with the baked (fitted) file")
    return p


def add_task_arguments(p):
    """The options that choose the operation and its settings (everything but the input and the
    output), added to `p`: the CLI's parser and `batch`'s share them. Returns their destinations."""
    before = {a.dest for a in p._actions}
    g = p.add_argument_group("targets", "Default: every object and pose bone of the active scene with "
                                        "rotation animation.")
    g.add_argument("--objects", action="append", metavar="PATTERN",
                   help="objects to bake, by name or glob pattern ('Arm*', 'Cube.00?'); repeatable, or "
                        "several patterns separated by commas. Armatures bring their animated pose bones. "
                        "Each pattern must match an object with rotation animation (itself or its bones)")
    g.add_argument("--bones", action="append", metavar="PATTERN",
                   help="of the armatures' pose bones, bake only these: bone name or glob ('Left*'), or "
                        "'Armature/Bone' patterns; repeatable or comma-separated. Objects are chosen by "
                        "--objects as before (their own rotation animation is still baked)")

    g = p.add_argument_group("method")
    g.add_argument("--method", choices=bake.METHODS, default="SLERP", metavar="METHOD",
                   help="interpolation between the keys (default SLERP): %s" % ", ".join(bake.METHODS))
    g.add_argument("--tension", type=float, default=0.0, metavar="T", help="TCB tension (default 0)")
    g.add_argument("--continuity", type=float, default=0.0, metavar="C", help="TCB continuity (default 0)")
    g.add_argument("--bias", type=float, default=0.0, metavar="B", help="TCB bias (default 0)")
    g.add_argument("--no-shortest-path", dest="shortest_path", action="store_false",
                   help="SLERP: keep the keyed quaternions' path instead of the shorter way")
    g.add_argument("--no-clamp", dest="clamped", action="store_false",
                   help="SQUAD, TCB, CATMULL_ROM (bake and fit): the textbook tangents instead of the "
                        "overshoot-free ones")

    g = p.add_argument_group("fit", "Instead of baking (the quatcurve.fit operator): the targets' own rotation keys "
                                    "stay, get fitted Bezier handles and as few generated keys as the tolerance "
                                    "needs, in their actions. Methods: %s." % ", ".join(fit.METHODS))
    g.add_argument("--fit", action="store_true",
                   help="fit instead of bake; uses --method, --tension, --continuity, --bias, "
                        "--no-shortest-path, --tolerance (default 0.05°) and --subframes (default 4)")

    g = p.add_argument_group("reduce", "Instead of baking (the quatcurve.reduce operator): the targets' rotation "
                                       "keys are replaced by as few keys as --tolerance allows (default 0.1°), "
                                       "measured at every frame and original key.")
    g.add_argument("--reduce", action="store_true",
                   help="reduce instead of bake; uses --tolerance, --reduce-keys, --synchronized, "
                        "--no-new-action")
    g.add_argument("--reduce-keys", dest="reduce_interpolation", choices=reduce.INTERPOLATIONS, default="BEZIER",
                   help="interpolation of the kept keys (default BEZIER: the fewest keys)")
    g.add_argument("--synchronized", action="store_true",
                   help="the same key frames on every rotation channel of a target")
    g.add_argument("--error", dest="reduce_error", choices=reduce.ERRORS, default="ANGLE",
                   help="the bound: ANGLE (default: each target's rotation within --tolerance) or DISTANCE "
                        "(per armature, every bone's tail and the points at --shell along its axes within "
                        "--distance in the armature's space). On a bake (not --reduce): DISTANCE bakes dense, "
                        "then reduces the baked keys so, against the dense bake. --clean: the same bound "
                        "instead of --deviation, at every frame that is not a spike")
    g.add_argument("--distance", type=float, default=0.0, metavar="LENGTH",
                   help="--error DISTANCE: how far a tail or shell point may move, in scene units (default 0: "
                        "1 mm in real size; --clean: the noise's reach, 2.5 × a bone's noise angle × how far "
                        "its vertices and its children's reach, the largest over the bones)")
    g.add_argument("--shell", type=float, default=0.0, metavar="LENGTH",
                   help="--error DISTANCE: the shell points' distance from each bone's head, in scene units "
                        "(default 0: 10 cm in real size)")

    g = p.add_argument_group("clean", "Instead of baking (the quatcurve.clean operator): the targets' captured "
                                      "rotations cleaned on the sphere of rotations — sign flips removed, spikes "
                                      "replaced, jitter smoothed within --deviation of every other frame (or with "
                                      "--error DISTANCE every virtual vertex within --distance) — into a new action "
                                      "(docs/clean.md).")
    g.add_argument("--clean", action="store_true",
                   help="clean instead of bake; uses --deviation (or --error DISTANCE, --distance, --shell), "
                        "--keep-spikes, --clean-reduce (with --tolerance, default 0.1°) and --no-new-action")
    g.add_argument("--deviation", type=float, default=0.0, metavar="DEG",
                   help="--clean: how far the cleaned rotation may stray from each frame that is not a spike, "
                        "in degrees (default 0: 2.5 times the clip's estimated noise, target by target)")
    g.add_argument("--keep-spikes", dest="clean_spikes", action="store_false",
                   help="--clean: do not look for spikes (every frame keeps the deviation bound)")
    g.add_argument("--clean-reduce", action="store_true",
                   help="--clean: reduce the cleaned keys (Bezier) within --tolerance of them at every instant; "
                        "default: one linear key per frame")

    g = p.add_argument_group("glTF", "Instead of baking (the quatcurve.export_gltf operator): the scene through "
                                     "Blender's glTF exporter, each rotation sampler replaced by few slerp "
                                     "keys within --tolerance (default 0.1°) of the target's curve at every "
                                     "instant, chosen among --subframes times per frame (default 20); with "
                                     "--error DISTANCE, every bone's virtual vertices within --distance (at "
                                     "--shell) of its curves' pose instead. IN.blend is not changed.")
    g.add_argument("--gltf", metavar="OUT.glb", help="the binary glTF file to write")
    g.add_argument("--gltf-curve", choices=gltf.METHODS, default="AUTO", metavar="CURVE",
                   help="the curve each rotation sampler plays: AUTO (default: fitted targets their fit's "
                        "method, others what Blender plays), BLENDER (what Blender plays), or a method "
                        "through each target's keys: %s" % ", ".join(fit.METHODS))

    g = p.add_argument_group("convert", "Instead of baking (the quatcurve.convert operator): the targets get a new "
                                        "rotation mode and their rotation keys are converted so that Blender plays "
                                        "the same motion, within --tolerance (default 0.05°) at --subframes points "
                                        "per frame (default 4).")
    g.add_argument("--convert", choices=convert.MODES, metavar="MODE",
                   help="the new rotation mode: %s" % ", ".join(convert.MODES))
    g.add_argument("--all-actions", action="store_true",
                   help="--convert: every action that animates a target's rotation (default: its active action)")

    g = p.add_argument_group("bake")
    g.add_argument("--rotation-mode", choices=bake.OUTPUT_MODES, default="KEEP", metavar="MODE",
                   help="rotation mode of the baked keys: %s (default KEEP: each target's own mode)"
                        % ", ".join(bake.OUTPUT_MODES))
    g.add_argument("--frame-range", type=float, nargs=2, metavar=("START", "END"),
                   help="frames to bake (default: the keyed range of the targets)")
    g.add_argument("--step", type=float, default=1.0, metavar="FRAMES", help="frames between baked keys, at least 1 (default 1)")
    g.add_argument("--tolerance", type=float, default=None, metavar="DEGREES",
                   help="bake: 0 (default): a key every STEP frames; above 0: as few keys as this angular "
                        "bound allows (key reduction). --fit: largest error of Blender's playback against "
                        "the method, above 0 (default 0.05). --reduce: largest error against the original "
                        "(default 0.1). --convert: largest change of the motion (default 0.05). --gltf: "
                        "largest error of the slerp keys against the curve (default 0.1)")
    g.add_argument("--no-new-action", dest="new_action", action="store_false",
                   help="replace the rotation curves in the targets' actions (default: bake into a new "
                        "action named after the original, which is kept unchanged)")

    g = p.add_argument_group("compare", "Before baking, on the original keys (the quatcurve.compare operator).")
    g.add_argument("--compare", action="store_true",
                   help="also compare the methods with Blender's Euler and quaternion modes and write "
                        "the JSON report and one plot PNG per target beside it")
    g.add_argument("--report", metavar="REPORT.json",
                   help="where the comparison report goes (implies --compare; default: the output file "
                        "with _compare.json instead of .blend)")
    g.add_argument("--subframes", type=int, default=None, metavar="N",
                   help="comparison samples per frame (default 1: every frame); --fit: points per frame "
                        "where the tolerance is checked (default 4)")
    g.add_argument("--all-euler-orders", action="store_true",
                   help="compare Blender's Euler mode in all six orders (default: the target's order)")
    g.add_argument("--compare-keys", dest="key_interpolation", choices=compare.KEY_INTERPOLATIONS,
                   default="BEZIER",
                   help="key type of the Blender Euler/quaternion curves compared (default BEZIER: "
                        "Blender's auto-clamped default)")
    return [a.dest for a in p._actions if a.dest not in before]


def blender_args(argv):
    """The arguments meant for this script: after '--' when Blender runs it, else argv[1:]."""
    return argv[argv.index("--") + 1:] if "--" in argv else argv[1:]


# ---- arguments → settings, paths ------------------------------------------------------------------

def split_patterns(values):
    return [p.strip() for v in values or () for p in v.split(",") if p.strip()]


def refuse_options(args, table, why):
    """UsageError naming the options of `table` ((dest, default, flag), argparse defaults: what is not
    given) that were given."""
    given = [flag for name, default, flag in table if getattr(args, name) != default]
    if given:
        raise UsageError("%s: %s" % (", ".join(given), why))


# Options only --reduce uses, and the distance bound's, which --reduce and the bake use.
REDUCE_KEYS_ONLY = (("reduce_interpolation", "BEZIER", "--reduce-keys"), ("synchronized", False, "--synchronized"))
DISTANCE_OPTIONS = (("reduce_error", "ANGLE", "--error"), ("distance", 0.0, "--distance"), ("shell", 0.0, "--shell"))
REDUCE_ONLY = REDUCE_KEYS_ONLY + DISTANCE_OPTIONS
# Options only --clean uses.
CLEAN_ONLY = (("deviation", 0.0, "--deviation"), ("clean_spikes", True, "--keep-spikes"),
              ("clean_reduce", False, "--clean-reduce"))


def bake_settings(args):
    """BakeSettings through the operator's own function; settings no bake can use are a UsageError."""
    refuse_options(args, REDUCE_KEYS_ONLY, "not an option of a bake (they are --reduce's)")
    refuse_options(args, CLEAN_ONLY, "not an option of a bake (they are --clean's)")
    if args.reduce_error == "DISTANCE" and args.tolerance is not None:
        raise UsageError("--tolerance: not an option of a bake with --error DISTANCE (its bound is --distance)")
    if args.reduce_error == "ANGLE" and (args.distance or args.shell):
        raise UsageError("--distance, --shell: options of --error DISTANCE")
    if args.tolerance is None:
        args.tolerance = 0.0
    frame_range = tuple(args.frame_range) if args.frame_range else (None, None)
    settings = bake_ops.settings_from(args, frame_range)
    settings.error = args.reduce_error
    try:
        bake.check_settings(settings)
        if args.frame_range:
            bake.bake_frames(frame_range[0], frame_range[1], settings.step)
    except bake.BakeError as error:
        raise UsageError(str(error)) from None
    return settings


# Bake and compare options that mean nothing to a fit (argparse defaults: what is not given).
NOT_FOR_FIT = (("rotation_mode", "KEEP", "--rotation-mode"), ("frame_range", None, "--frame-range"),
               ("step", 1.0, "--step"), ("new_action", True, "--no-new-action"), ("compare", False, "--compare"),
               ("report", None, "--report"), ("all_euler_orders", False, "--all-euler-orders"),
               ("key_interpolation", "BEZIER", "--compare-keys")) + REDUCE_ONLY + CLEAN_ONLY


def fit_settings(args):
    """FitSettings from the arguments (the operator's defaults where not given), checked by fit's own
    check; bake-only options and methods fit does not have are a UsageError."""
    refuse_options(args, NOT_FOR_FIT, "not an option of --fit (it fits the keys in their own actions and modes)")
    if args.method not in fit.METHODS:
        raise UsageError("--method %s cannot be fitted (--fit methods: %s)" % (args.method, ", ".join(fit.METHODS)))
    defaults = fit.FitSettings()
    settings = fit.FitSettings(
        method=args.method, tension=args.tension, continuity=args.continuity, bias=args.bias,
        shortest_path=args.shortest_path, clamped=args.clamped,
        tolerance=defaults.tolerance if args.tolerance is None else args.tolerance,
        subframes=defaults.subframes if args.subframes is None else args.subframes)
    try:
        fit.check_settings(settings)
    except fit.FitError as error:
        raise UsageError(str(error)) from None
    return settings


# Options that mean nothing to a reduction: it keeps each target's keys' own mode and curve.
NOT_FOR_REDUCE = (("method", "SLERP", "--method"), ("tension", 0.0, "--tension"), ("continuity", 0.0, "--continuity"),
                  ("bias", 0.0, "--bias"), ("shortest_path", True, "--no-shortest-path"),
                  ("clamped", True, "--no-clamp"), ("rotation_mode", "KEEP", "--rotation-mode"),
                  ("frame_range", None, "--frame-range"), ("step", 1.0, "--step"), ("compare", False, "--compare"),
                  ("report", None, "--report"), ("subframes", None, "--subframes"),
                  ("all_euler_orders", False, "--all-euler-orders"), ("key_interpolation", "BEZIER", "--compare-keys"),
                  ("all_actions", False, "--all-actions"), ("gltf_curve", "AUTO", "--gltf-curve"))


def reduce_settings(args):
    """ReduceSettings from the arguments (the operator's defaults where not given), checked by reduce's
    own check; options of other operations are a UsageError."""
    refuse_options(args, NOT_FOR_REDUCE + CLEAN_ONLY,
                   "not an option of --reduce (it reduces the keys as Blender plays them)")
    defaults = reduce.ReduceSettings()
    settings = reduce.ReduceSettings(
        tolerance=defaults.tolerance if args.tolerance is None else args.tolerance,
        interpolation=args.reduce_interpolation, synchronized=args.synchronized, new_action=args.new_action,
        error=args.reduce_error, distance=args.distance, shell=args.shell)
    if settings.error == "DISTANCE" and args.tolerance is not None:
        raise UsageError("--tolerance: not an option of --reduce --error DISTANCE (its bound is --distance)")
    if settings.error == "ANGLE" and (args.distance or args.shell):
        raise UsageError("--distance, --shell: options of --error DISTANCE")
    try:
        reduce.check_settings(settings)
    except reduce.ReduceError as error:
        raise UsageError(str(error)) from None
    return settings


def clean_settings(args):
    """CleanSettings from the arguments (the operator's defaults where not given), checked by clean's
    own check; options of other operations are a UsageError."""
    refuse_options(args, NOT_FOR_REDUCE + REDUCE_KEYS_ONLY,
                   "not an option of --clean (it cleans the keys as Blender plays them, in their own modes)")
    if args.tolerance is not None and not args.clean_reduce:
        raise UsageError("--tolerance: an option of --clean only with --clean-reduce (the reduction's bound)")
    if args.reduce_error == "ANGLE" and (args.distance or args.shell):
        raise UsageError("--distance, --shell: options of --error DISTANCE")
    if args.reduce_error == "DISTANCE" and args.deviation:
        raise UsageError("--deviation: not an option of --clean --error DISTANCE (its bound is --distance)")
    defaults = clean.CleanSettings()
    settings = clean.CleanSettings(
        deviation=args.deviation, spikes=args.clean_spikes, reduce=args.clean_reduce,
        tolerance=defaults.tolerance if args.tolerance is None else args.tolerance, new_action=args.new_action,
        error=args.reduce_error, distance=args.distance, shell=args.shell)
    try:
        clean.check_settings(settings)
    except clean.CleanError as error:
        raise UsageError(str(error)) from None
    return settings


# Options that mean nothing to a conversion (argparse defaults: what is not given).
NOT_FOR_CONVERT = NOT_FOR_FIT + (
    ("fit", False, "--fit"), ("method", "SLERP", "--method"), ("tension", 0.0, "--tension"),
    ("continuity", 0.0, "--continuity"), ("bias", 0.0, "--bias"), ("shortest_path", True, "--no-shortest-path"),
    ("clamped", True, "--no-clamp"), ("reduce", False, "--reduce"))


def convert_settings(args):
    """ConvertSettings from the arguments (the operator's defaults where not given), checked by
    convert's own check; options of the other tasks are a UsageError."""
    refuse_options(args, NOT_FOR_CONVERT, "not an option of --convert (it converts the keys in their own actions)")
    defaults = convert.ConvertSettings()
    settings = convert.ConvertSettings(
        rotation_mode=args.convert, actions="ALL" if args.all_actions else "ACTIVE",
        tolerance=defaults.tolerance if args.tolerance is None else args.tolerance,
        subframes=defaults.subframes if args.subframes is None else args.subframes)
    try:
        convert.check_settings(settings)
    except convert.ConvertError as error:
        raise UsageError(str(error)) from None
    return settings


# Options of bake, fit and compare that mean nothing to --gltf (argparse defaults: what is not given).
NOT_FOR_GLTF = tuple(o for o in NOT_FOR_FIT if o not in DISTANCE_OPTIONS) + (("fit", False, "--fit"),
                              ("objects", None, "--objects"), ("bones", None, "--bones"), ("method", "SLERP", "--method"),
                              ("tension", 0.0, "--tension"), ("continuity", 0.0, "--continuity"), ("bias", 0.0, "--bias"),
                              ("shortest_path", True, "--no-shortest-path"), ("clamped", True, "--no-clamp"),
                              ("convert", None, "--convert"), ("all_actions", False, "--all-actions"),
                              ("reduce", False, "--reduce"))


def gltf_settings(args):
    """ExportSettings from the arguments, checked with the output path by gltf's own check; options of
    the other tasks are a UsageError."""
    refuse_options(args, NOT_FOR_GLTF, "not an option of --gltf (it exports the whole scene; choose the curve "
                                       "with --gltf-curve)")
    defaults = gltf.ExportSettings()
    if args.reduce_error == "DISTANCE" and args.tolerance is not None:
        raise UsageError("--tolerance: not an option of --gltf --error DISTANCE (its bound is --distance)")
    if args.reduce_error == "ANGLE" and (args.distance or args.shell):
        raise UsageError("--distance, --shell: options of --error DISTANCE")
    settings = gltf.ExportSettings(
        method=args.gltf_curve, tolerance=defaults.tolerance if args.tolerance is None else args.tolerance,
        subframes=defaults.subframes if args.subframes is None else args.subframes, error=args.reduce_error,
        distance=args.distance, shell=args.shell)
    try:
        gltf.check_settings(settings, args.gltf)
    except gltf.GltfError as error:
        raise UsageError("--gltf: %s" % error) from None
    return settings


def compare_settings(args):
    if args.subframes is None:
        args.subframes = 1
    settings = compare.CompareSettings(subframes=args.subframes, all_euler_orders=args.all_euler_orders,
                                       key_interpolation=args.key_interpolation, tension=args.tension,
                                       continuity=args.continuity, bias=args.bias)
    try:
        compare.check_settings(settings)
    except compare.CompareError as error:
        raise UsageError(str(error)) from None
    return settings


def input_path(args):
    """Absolute path of IN.blend: the argument, or the file Blender was started with."""
    loaded = bpy.data.filepath
    if args.input is None:
        if not loaded:
            raise UsageError("no input file: give IN.blend")
        return os.path.abspath(loaded)
    path = os.path.abspath(args.input)
    if not os.path.isfile(path):
        raise UsageError("input %s: no such file" % args.input)
    if loaded and not os.path.samefile(loaded, path):
        raise UsageError("two input files: %s (opened by Blender) and %s" % (loaded, args.input))
    return path


def output_path(args, source):
    """Absolute path the baked file is saved to; checked before any work is done."""
    if args.in_place and args.output:
        raise UsageError("--output and --in-place exclude each other")
    if args.in_place:
        if not source.lower().endswith(".blend"):
            raise UsageError("--in-place: %s is imported, not a .blend: give --output OUT.blend"
                             % os.path.basename(source))
        return source
    if not args.output:
        raise UsageError("no output: give --output OUT.blend (or --in-place to overwrite the input)")
    path = os.path.abspath(args.output)
    folder = os.path.dirname(path)
    if not path.endswith(".blend"):
        raise UsageError("--output %s: not a .blend file name" % args.output)
    if not os.path.isdir(folder):
        raise UsageError("--output %s: folder %s does not exist" % (args.output, folder))
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError("--output %s: folder %s is not writable" % (args.output, folder))
    if os.path.isdir(path):
        raise UsageError("--output %s: is a folder" % args.output)
    if os.path.exists(path) and os.path.samefile(path, source):
        raise UsageError("--output %s is the input file: use --in-place to overwrite it" % args.output)
    return path


def report_path(args, output):
    if args.report is None:
        return output[:-len(".blend")] + "_compare.json" if output.endswith(".blend") else output + "_compare.json"
    path = os.path.abspath(args.report)
    if os.path.isdir(path):
        raise UsageError("--report %s: is a folder" % args.report)
    existing = os.path.dirname(path)  # the report's folder is created if missing: it must be possible
    while not os.path.exists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        raise UsageError("--report %s: %s is not a folder" % (args.report, existing))
    return path


def open_input(path):
    """Opens IN.blend unless Blender already did, or imports a .bvh, .fbx, .glb or .gltf file into an
    empty scene (inputs.read); an unreadable file is a UsageError saying what the reader raised and
    the likely cause."""
    if bpy.data.filepath and os.path.samefile(bpy.data.filepath, path):
        return
    try:
        with output_held():
            inputs.read(path)
    except inputs.InputError as error:
        raise UsageError("input %s: cannot read it: %s" % (path, error)) from None


@contextlib.contextmanager
def output_held():
    """Holds what is printed to stdout and stderr (file descriptors 1 and 2: Blender's C code and its
    importers) meanwhile: given back when the block succeeds, dropped when it raises — a failed
    import prints its whole traceback, which the one error line replaces (QUATCURVE_DEBUG=1: nothing
    is held)."""
    if os.environ.get("QUATCURVE_DEBUG"):
        yield
        return
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [(fd, os.dup(fd), tempfile.TemporaryFile()) for fd in (1, 2)]
    failed = True
    try:
        for fd, _, held in saved:
            os.dup2(held.fileno(), fd)
        yield
        failed = False
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        for fd, original, held in saved:
            os.dup2(original, fd)
            os.close(original)
            if not failed:
                held.seek(0)
                data = held.read()
                while data:
                    data = data[os.write(fd, data):]
            held.close()


def register_addon():
    """Registers the add-on's operators and settings unless an enabled add-on already did; returns
    True when it registered (the caller then unregisters: the bpy 4.5 module hangs at exit while an
    operator class is still registered)."""
    if hasattr(bpy.types.Scene, "quatcurve"):
        return False
    addon.register()
    return True


# ---- targets by name or glob ----------------------------------------------------------------------

def matches(name, pattern):
    return name == pattern or fnmatch.fnmatchcase(name, pattern)


def no_animation_reason(target):
    """bake's own explanation of why `target` has nothing to bake."""
    try:
        targets.read_rotation_keys(target)
    except targets.TargetError as error:
        return str(error)
    return "%s: no rotation animation" % target.name


def select_targets(objects, object_patterns, bone_patterns):
    """The bake targets among `objects`, sorted by name. --objects chooses objects (default all);
    an armature among them brings its animated pose bones, which --bones narrows to the matching
    ones. Every target has rotation animation. A pattern that matches nothing, or only things
    without rotation animation, is a UsageError."""
    objects = sorted(objects, key=lambda o: o.name)
    chosen = objects
    if object_patterns:
        chosen = []
        for pattern in object_patterns:
            found = [o for o in objects if matches(o.name, pattern)]
            if not found:
                raise UsageError("--objects %r: no object matches (objects: %s)"
                                 % (pattern, _names([o.name for o in objects])))
            if not targets.animated_targets(found):
                raise UsageError("--objects %r: %s" % (pattern, no_animation_reason(targets.Target(found[0]))))
            chosen += [o for o in found if o not in chosen]
    found_targets = targets.animated_targets(chosen)
    if bone_patterns:
        bones = [targets.Target(o, pb.name) for o in chosen if o.type == "ARMATURE" and o.pose is not None
                 for pb in o.pose.bones]
        keep = set()
        for pattern in bone_patterns:
            key = (lambda t: t.name) if "/" in pattern else (lambda t: t.bone)
            found = [t for t in bones if matches(key(t), pattern)]
            if not found:
                raise UsageError("--bones %r: no pose bone matches (%s)" % (
                    pattern, "armatures: " + _names(sorted({t.object.name for t in bones})) if bones
                    else "no armature among the objects"))
            animated = [t for t in found if targets.has_rotation_animation(t)]
            if not animated:
                raise UsageError("--bones %r: %s" % (pattern, no_animation_reason(found[0])))
            keep.update(t.name for t in animated)
        found_targets = [t for t in found_targets if t.bone is None or t.name in keep]
    if not found_targets:
        raise UsageError("no object or pose bone with rotation animation in the scene")
    return sorted(found_targets, key=lambda t: (t.object.name, t.bone or ""))


def _names(names, limit=12):
    names = list(names)
    return ", ".join(names[:limit]) + (", … (%d)" % len(names) if len(names) > limit else "") if names else "none"


# ---- saving -----------------------------------------------------------------------------------------

@contextlib.contextmanager
def blender_output_silenced():
    """Sends what Blender's C code prints to stdout (file descriptor 1) to /dev/null meanwhile."""
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def save_atomically(path):
    """Saves the open file as `path`: to a temporary file in the same folder first, renamed over
    `path` once complete (copy=True: the session keeps its own file path)."""
    folder, name = os.path.split(path)
    temporary = os.path.join(folder, ".%s.%s.tmp.blend" % (name, uuid.uuid4().hex[:12]))
    try:
        with blender_output_silenced():  # Blender's "Info: Saved <temporary name>"
            result = bpy.ops.wm.save_as_mainfile(filepath=temporary, copy=True)
        if "FINISHED" not in result or not os.path.isfile(temporary):
            raise OSError("saving %s failed (%s)" % (path, ", ".join(sorted(result))))
        os.replace(temporary, path)
    except RuntimeError as error:
        raise OSError("saving %s failed: %s" % (path, str(error).strip().replace("\n", " "))) from None
    finally:
        for leftover in (temporary, temporary + "1"):
            if os.path.exists(leftover):
                os.remove(leftover)


# ---- tasks: what is done to the open file ----------------------------------------------------------

class Outcome:
    """What a task did, in the terms every task shares (batch's records): the targets' names, rotation
    keys before and after (as the task counts them), and the largest error measured after the
    operation by the task's own check, in degrees (None where the task has no bound: a bake with
    tolerance 0 writes the method's samples themselves). max_distance: a reduction under the distance
    bound's worst virtual-vertex distance in scene units (its bound is not an angle), else None."""

    def __init__(self, targets, keys_before, keys_after, max_error_deg, max_distance=None, clean=None):
        self.targets = list(targets)
        self.keys_before = int(keys_before)
        self.keys_after = int(keys_after)
        self.max_error_deg = None if max_error_deg is None else float(max_error_deg)
        self.max_distance = None if max_distance is None else float(max_distance)
        self.clean = clean  # --clean: {spike_frames, flips, noise_deg} (batch's record "clean")


class Task:
    """One operation of the command line. Made from the parsed arguments, it checks its settings
    before any file is opened (UsageError); then, on the open file, `apply` works on the chosen
    targets and prints what it did, and `save` writes the output .blend (and any file of its own,
    named after it). `cli` runs one task on one file; `batch` runs the same task on many files, one
    after the other in each process. A new operation is a Task subclass added to TASKS."""
    flag = None       # the option that chooses it (None: the default, bake)
    verb = "bake"
    output_suffix = ".blend"   # what `save` writes (batch names each file's output with it)
    selects_targets = True     # False: `apply` gets None and works on the whole scene

    def __init__(self, args):
        self.args = args

    def check_output(self, output):
        """Checks the paths of the task's own files, derived from the output .blend."""

    def apply(self, chosen, source, output):
        """Works on `chosen` (targets.Target) in the open file; prints; returns the task's result."""
        raise NotImplementedError

    def outcome(self, result):
        raise NotImplementedError

    def report(self, result, scene_attr, what, source, output):
        """After the task's function ran: Blender re-evaluates the scene (as the operator does), the
        panel's last result is stored in scene.<scene_attr>, and the result is printed: a header
        naming `what` was done, one line per target, the total."""
        scene = bpy.context.scene
        scene.frame_set(scene.frame_current)
        if hasattr(scene, scene_attr):
            getattr(scene, scene_attr).last_summary = result.summary()
            getattr(scene, scene_attr).last_lines = "\n".join(result.lines())
        print("quatcurve %s (Blender %s): %s, %s → %s" % (
            native.require().__version__, bpy.app.version_string, what, os.path.basename(source),
            "in place" if source == output else output))
        for line in result.lines():
            print("  " + line)
        print("total: " + result.summary())
        return result

    def save(self, result, output):
        save_atomically(output)
        print("saved %s" % output)


class BakeTask(Task):
    def __init__(self, args):
        super().__init__(args)
        self.settings = bake_settings(args)
        want_compare = args.compare or args.report is not None
        self.comparing = compare_settings(args) if want_compare else None
        self.report = None
        self.report_file = None

    def check_output(self, output):
        if self.comparing is not None:
            self.report_file = report_path(self.args, output)

    def apply(self, chosen, source, output):
        settings, scene = self.settings, bpy.context.scene
        report = compare.compare(chosen, self.comparing) if self.comparing is not None else None
        result = bake.bake(chosen, settings)
        scene.frame_set(scene.frame_current)  # re-evaluate with the baked curves, as the operator does
        if hasattr(scene, "quatcurve"):
            bake_ops.store_result(scene.quatcurve, result)
        if report is not None and hasattr(scene, "quatcurve_compare"):
            compare_ops.store_result(scene.quatcurve_compare, report)
        print("quatcurve %s (Blender %s): %s, frames %g..%g step %g, %s → %s" % (
            native.require().__version__, bpy.app.version_string, methods.label_and_id(settings.method),
            result.frame_start, result.frame_end, settings.step, os.path.basename(source),
            "in place" if source == output else output))
        for line in result.lines():
            print("  " + line)
        print("total: " + result.summary())
        self.report = report
        return result

    def outcome(self, result):
        errors = [t.max_error_deg for t in result.targets if t.max_error_deg is not None]
        # keys_written counts the keys of every channel: count the source's the same way.
        before = sum(t.source_keys * (4 if t.source_mode in ("QUATERNION", "AXIS_ANGLE") else 3)
                     for t in result.targets)
        return Outcome([t.name for t in result.targets], before, result.keys_written,
                       max(errors) if errors else None, max_distance=result.worst_distance)

    def save(self, result, output):
        report = self.report
        if report is not None:  # the plots as PNG files, then packed from them into the .blend saved next
            compare.save_plots(report, self.report_file)
        super().save(result, output)
        if report is not None:
            path, pngs = compare.write_report(report, self.report_file)
            print("compare: %s; wrote %s and %d plot%s" % (report.summary(), path, len(pngs),
                                                            "" if len(pngs) == 1 else "s"))


class FitTask(Task):
    flag, verb = "fit", "fit"

    def __init__(self, args):
        super().__init__(args)
        self.settings = fit_settings(args)

    def apply(self, chosen, source, output):
        settings = self.settings
        return self.report(fit.fit(chosen, settings), "quatcurve_fit", "fit %s, tolerance %g°, %d subframes" % (
            methods.label_and_id(settings.method), settings.tolerance, settings.subframes), source, output)

    def outcome(self, result):
        fitted = result.fitted
        return Outcome([t.name for t in result.targets], sum(t.animator_keys for t in result.targets),
                       sum(t.animator_keys + t.generated_keys for t in result.targets),
                       max([t.max_error_deg for t in fitted] or [0.0]))


class ReduceTask(Task):
    flag, verb = "reduce", "reduce"

    def __init__(self, args):
        super().__init__(args)
        self.settings = reduce_settings(args)

    def apply(self, chosen, source, output):
        settings = self.settings
        result = reduce.reduce(chosen, settings)
        bound = ("tolerance %g°" % settings.tolerance if settings.error == "ANGLE" else
                 "distance %s, shell %s" % (result.length(result.distance), result.length(result.shell)))
        return self.report(result, "quatcurve_reduce", "reduce, %s, %s keys" % (bound, settings.interpolation),
                           source, output)

    def outcome(self, result):
        if result.error == "DISTANCE":
            return Outcome([t.name for t in result.targets], result.keys_before, result.keys_after, None,
                           max_distance=result.worst_distance)
        return Outcome([t.name for t in result.targets], result.keys_before, result.keys_after,
                       result.max_error_deg)


class CleanTask(Task):
    flag, verb = "clean", "clean"

    def __init__(self, args):
        super().__init__(args)
        self.settings = clean_settings(args)

    def apply(self, chosen, source, output):
        settings = self.settings
        result = clean.clean(chosen, settings)
        if settings.error == "DISTANCE":
            bound = "distance %s%s, shell %s" % (result.length(result.distance), "" if settings.distance else
                                                 " (the noise's reach)", result.length(result.shell))
        else:
            bound = "deviation %s" % ("%g°" % settings.deviation if settings.deviation else "2.5 × noise")
        if settings.reduce:
            bound += ", reduced within %g°" % settings.tolerance
        return self.report(result, "quatcurve_clean", "clean, " + bound, source, output)

    def outcome(self, result):
        # The error: the largest deviation from a frame that is not a spike (plus the reduction's bound);
        # under DISTANCE the worst virtual-vertex distance there, and the bound in the record.
        figures = {"spike_frames": result.spike_frames, "flips": sum(t.flips for t in result.targets),
                   "noise_deg": round(max([t.noise_deg for t in result.targets] or [0.0]), 6)}
        keys = (sum(t.keys_before for t in result.targets), sum(t.keys_after for t in result.targets))
        if result.distance is not None:
            figures.update(distance=float("%.9g" % result.distance), shell=float("%.9g" % result.shell))
            return Outcome([t.name for t in result.targets], *keys, None, max_distance=result.worst_distance,
                           clean=figures)
        worst = max([t.max_deviation_deg for t in result.targets] or [0.0])
        if result.settings.reduce:
            worst += result.settings.tolerance
        return Outcome([t.name for t in result.targets], *keys, worst, clean=figures)


class ConvertTask(Task):
    flag, verb = "convert", "convert"

    def __init__(self, args):
        super().__init__(args)
        self.settings = convert_settings(args)

    def apply(self, chosen, source, output):
        settings, scene = self.settings, bpy.context.scene
        result = convert.convert(chosen, settings)
        scene.frame_set(scene.frame_current)  # re-evaluate in the new modes, as the operator does
        print("quatcurve %s (Blender %s): convert to %s, tolerance %g°, %d subframes, %s actions, %s → %s" % (
            native.require().__version__, bpy.app.version_string, settings.rotation_mode, settings.tolerance,
            settings.subframes, settings.actions.lower(), os.path.basename(source),
            "in place" if source == output else output))
        for line in result.lines():
            print("  " + line)
        print("total: " + result.summary())
        return result

    def outcome(self, result):
        rows = [a for t in result.converted for a in t.actions]  # (action, before, after, generated, max error °)
        return Outcome([t.name for t in result.targets], sum(r[1] for r in rows), sum(r[2] for r in rows),
                       max([r[4] for r in rows] or [0.0]))


class GltfTask(Task):
    """--gltf OUT.glb: the scene exported (gltf.export); no .blend is saved. In a batch, each file's
    glTF is its output (DIR/<input>.glb) and the path given to --gltf is only checked."""
    flag, verb = "gltf", "gltf"
    output_suffix = ".glb"
    selects_targets = False

    def __init__(self, args):
        super().__init__(args)
        self.settings = gltf_settings(args)

    def apply(self, chosen, source, output):
        settings = self.settings
        with blender_output_silenced():  # the exporter's progress lines
            result = gltf.export(bpy.context.scene, output, settings)
        curve = methods.label_and_id(settings.method) if settings.method in methods.ALL else settings.method
        if settings.error == "DISTANCE":
            scene = bpy.context.scene
            distance, shell = reduce.scene_lengths(settings, scene)
            units = (scene.unit_settings.system, scene.unit_settings.scale_length or 1.0)
            bound = "distance %s, shell %s" % (reduce.length_text(distance, *units), reduce.length_text(shell, *units))
        else:
            bound = "tolerance %g°" % settings.tolerance
        print("quatcurve %s (Blender %s): glTF, curve %s, %s, %d subframes, %s -> %s" % (
            native.require().__version__, bpy.app.version_string, curve, bound,
            settings.subframes, os.path.basename(source), result.filepath))
        for line in result.lines():
            print("  " + line)
        print("total: " + result.summary())
        return result

    def outcome(self, result):
        if result.settings.error == "DISTANCE":
            return Outcome(sorted({s.target for s in result.samplers}), result.keys_before, result.keys_after, None,
                           max_distance=max([d.distance for d in result.distances] or [0.0]))
        return Outcome(sorted({s.target for s in result.samplers}), result.keys_before, result.keys_after,
                       math.degrees(result.max_error))

    def save(self, result, output):
        """gltf.export has written the file (complete or not at all)."""


# The operations, chosen by their option; BakeTask when none is given.
TASKS = (GltfTask, ConvertTask, FitTask, ReduceTask, CleanTask)


def task_of(args):
    """The Task the arguments ask for, its settings checked (UsageError)."""
    chosen = [cls for cls in TASKS if getattr(args, cls.flag) not in (None, False)]
    if len(chosen) > 1:
        raise UsageError("%s exclude each other" % " and ".join("--" + cls.flag.replace("_", "-") for cls in chosen))
    if GltfTask not in chosen and args.gltf_curve != "AUTO":
        raise UsageError("--gltf-curve: an option of --gltf only")
    if ConvertTask not in chosen and args.all_actions:
        raise UsageError("--all-actions: an option of --convert only")
    return (chosen[0] if chosen else BakeTask)(args)


# ---- main -------------------------------------------------------------------------------------------

def run(args):
    task = task_of(args)
    source = input_path(args)
    # A task that saves no .blend names its own output (--gltf OUT.glb, checked with its settings).
    if task.output_suffix == ".blend":
        output = output_path(args, source)
    else:
        refuse_options(args, (("output", None, "--output"), ("in_place", False, "--in-place")),
                       "not an option of --%s (it writes %s: IN.blend is not changed)" % (task.flag, getattr(args, task.flag)))
        output = os.path.abspath(getattr(args, task.flag))
    task.check_output(output)
    native.require()
    open_input(source)
    registered = register_addon()
    try:
        scene = bpy.context.scene
        chosen = None
        if task.selects_targets:
            chosen = select_targets(scene.objects, split_patterns(args.objects), split_patterns(args.bones))
        result = task.apply(chosen, source, output)
        task.save(result, output)
        return EXIT_OK
    finally:
        if registered:
            addon.unregister()


def main(argv=None):
    """Runs the CLI on `argv` (default: sys.argv as Blender or Python passed it); returns the exit
    status. Errors are printed as one line on stderr."""
    argv = blender_args(sys.argv if argv is None else argv)
    begin = time.perf_counter()
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as done:  # --help
        return int(done.code or 0)
    except UsageError as error:
        return fail(EXIT_USAGE, "%s (see --help)" % error)
    try:
        code = run(args)
    except UsageError as error:
        return fail(EXIT_USAGE, str(error))
    except (targets.TargetError, RuntimeError, OSError) as error:
        return fail(EXIT_FAILURE, str(error))
    except Exception as error:  # a bug: still one line, the traceback on request
        if os.environ.get("QUATCURVE_DEBUG"):
            traceback.print_exc()
        return fail(EXIT_FAILURE, "internal error: %s: %s" % (type(error).__name__, error))
    print("done in %.2f s" % (time.perf_counter() - begin))
    return code


def fail(code, message):
    sys.stdout.flush()
    print("quatcurve: error: " + " ".join(str(message).split()), file=sys.stderr)
    sys.stderr.flush()
    return code


def exit_with(code):
    """Ends the process with `code`. Blender (3.4 to 5.0) ends with the status of a SystemExit
    raised by its --python script; streams are flushed first."""
    sys.stdout.flush()
    sys.stderr.flush()
    sys.exit(code)


if __name__ == "__main__":
    exit_with(main())
