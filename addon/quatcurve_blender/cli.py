"""Batch baking and fitting from the command line: bake (and optionally compare), or fit (`--fit`),
the rotations in a .blend file without Blender's UI.

    blender --background --python addon/quatcurve_blender/cli.py -- [options] IN.blend
    blender --background IN.blend --python addon/quatcurve_blender/cli.py -- [options]
    PYTHONPATH=addon python -m quatcurve_blender.cli [options] IN.blend     (a Python with the bpy module)

Exit status: 0 success; 2 bad arguments (unknown option, method, object or bone, bad frame range,
missing input, output that cannot be written); 1 failure (the bake, the comparison or the save
failed). Every error is one line on stderr, `quatcurve: error: <reason>`, without a traceback
(QUATCURVE_DEBUG=1 adds the traceback of unexpected errors). Nothing is saved unless everything
succeeded. IN.blend is only written with --in-place; the output is saved to a temporary file in the
same folder and renamed over the target, so it is either complete or untouched.

This module parses arguments and selects targets by name or glob pattern; the work is done by the
functions the operators call (bake.bake, compare.compare / save_plots / write_report, fit.fit).

When Blender runs this file as a script (`--python cli.py`) it is not inside its package: the
add-on's parent folder is put on sys.path and the package is imported (and registered) by name.
A missing or unreadable IN.blend given *before* `--python` is refused by Blender itself (exit status
1, before this script runs); given after `--`, it is this script's exit status 2.
"""

import argparse
import contextlib
import fnmatch
import os
import sys
import time
import traceback
import uuid

if __package__:
    from . import bake, bake_ops, compare, compare_ops, convert, fit, fit_ops, gltf, native, targets
    addon = sys.modules[__package__]
else:  # `blender --python cli.py` (or `python cli.py`): a script outside its package
    _here = os.path.dirname(os.path.abspath(__file__))
    # `python cli.py` puts this folder first on sys.path, where the add-on's modules would shadow
    # top-level names: import them only through the package, from the folder above.
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != _here]
    sys.path.insert(0, os.path.dirname(_here))
    import quatcurve_blender as addon
    from quatcurve_blender import bake, bake_ops, compare, compare_ops, convert, fit, fit_ops, gltf, native, targets

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
                           "quatcurve.fit operator); or, with --convert MODE, change their rotation mode\n"
                           "keeping the motion (the quatcurve.convert operator); or, with --gltf, export the\n"
                           "scene to binary glTF with few rotation keys that play each target's curve\n"
                           "(the quatcurve.export_gltf operator).")
    p.add_argument("input", nargs="?", metavar="IN.blend",
                   help="the file to bake (may be omitted when Blender was started with it: "
                        "blender -b IN.blend --python cli.py -- ...)")

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

    g = p.add_argument_group("glTF", "Instead of baking (the quatcurve.export_gltf operator): the scene through "
                                     "Blender's glTF exporter, each rotation sampler replaced by few slerp "
                                     "keys within --tolerance (default 0.1°) of the target's curve, checked at "
                                     "--subframes points per frame (default 20). IN.blend is not changed.")
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
                        "the method, above 0 (default 0.05)")
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

    g = p.add_argument_group("output", "One of them is required.")
    g.add_argument("--output", metavar="OUT.blend", help="the baked (fitted) file (IN.blend is not changed)")
    g.add_argument("--in-place", action="store_true", help="overwrite IN.blend with the baked (fitted) file")
    return p


def blender_args(argv):
    """The arguments meant for this script: after '--' when Blender runs it, else argv[1:]."""
    return argv[argv.index("--") + 1:] if "--" in argv else argv[1:]


# ---- arguments → settings, paths ------------------------------------------------------------------

def split_patterns(values):
    return [p.strip() for v in values or () for p in v.split(",") if p.strip()]


def bake_settings(args):
    """BakeSettings through the operator's own function; settings no bake can use are a UsageError."""
    if args.tolerance is None:
        args.tolerance = 0.0
    frame_range = tuple(args.frame_range) if args.frame_range else (None, None)
    settings = bake_ops.settings_from(args, frame_range)
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
               ("key_interpolation", "BEZIER", "--compare-keys"))


def fit_settings(args):
    """FitSettings from the arguments (the operator's defaults where not given), checked by fit's own
    check; bake-only options and methods fit does not have are a UsageError."""
    given = [flag for name, default, flag in NOT_FOR_FIT if getattr(args, name) != default]
    if given:
        raise UsageError("%s: not an option of --fit (it fits the keys in their own actions and modes)"
                         % ", ".join(given))
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


# Options that mean nothing to a conversion (argparse defaults: what is not given).
NOT_FOR_CONVERT = NOT_FOR_FIT + (
    ("fit", False, "--fit"), ("method", "SLERP", "--method"), ("tension", 0.0, "--tension"),
    ("continuity", 0.0, "--continuity"), ("bias", 0.0, "--bias"), ("shortest_path", True, "--no-shortest-path"),
    ("clamped", True, "--no-clamp"))


def convert_settings(args):
    """ConvertSettings from the arguments (the operator's defaults where not given), checked by
    convert's own check; options of the other tasks are a UsageError."""
    given = [flag for name, default, flag in NOT_FOR_CONVERT if getattr(args, name) != default]
    if given:
        raise UsageError("%s: not an option of --convert (it converts the keys in their own actions)"
                         % ", ".join(given))
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
NOT_FOR_GLTF = NOT_FOR_FIT + (("fit", False, "--fit"), ("output", None, "--output"), ("in_place", False, "--in-place"),
                              ("objects", None, "--objects"), ("bones", None, "--bones"), ("method", "SLERP", "--method"),
                              ("tension", 0.0, "--tension"), ("continuity", 0.0, "--continuity"), ("bias", 0.0, "--bias"),
                              ("shortest_path", True, "--no-shortest-path"), ("clamped", True, "--no-clamp"),
                              ("convert", None, "--convert"), ("all_actions", False, "--all-actions"))


def gltf_settings(args):
    """ExportSettings from the arguments, checked with the output path by gltf's own check; options of
    the other tasks are a UsageError."""
    given = [flag for name, default, flag in NOT_FOR_GLTF if getattr(args, name) != default]
    if given:
        raise UsageError("%s: not an option of --gltf (it exports the whole scene; choose the curve with "
                         "--gltf-curve)" % ", ".join(given))
    defaults = gltf.ExportSettings()
    settings = gltf.ExportSettings(
        method=args.gltf_curve, tolerance=defaults.tolerance if args.tolerance is None else args.tolerance,
        subframes=defaults.subframes if args.subframes is None else args.subframes)
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
    """Opens IN.blend unless Blender already did; an unreadable file is a UsageError."""
    if bpy.data.filepath and os.path.samefile(bpy.data.filepath, path):
        return
    try:
        bpy.ops.wm.open_mainfile(filepath=path, load_ui=False)
    except RuntimeError as error:
        raise UsageError("input %s: %s" % (path, str(error).strip().replace("\n", " "))) from None


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


# ---- main -------------------------------------------------------------------------------------------

def run(args):
    if args.gltf is not None:
        return run_gltf(args)
    if args.gltf_curve != "AUTO":
        raise UsageError("--gltf-curve: an option of --gltf only")
    if args.convert:
        return run_convert(args)
    if args.all_actions:
        raise UsageError("--all-actions: an option of --convert only")
    if args.fit:
        return run_fit(args)
    settings = bake_settings(args)
    want_compare = args.compare or args.report is not None
    comparing = compare_settings(args) if want_compare else None
    source = input_path(args)
    output = output_path(args, source)
    report_file = report_path(args, output) if want_compare else None
    native.require()
    open_input(source)
    registered = register_addon()
    try:
        return bake_and_save(args, settings, comparing, source, output, report_file)
    finally:
        if registered:
            addon.unregister()


def bake_and_save(args, settings, comparing, source, output, report_file):
    scene = bpy.context.scene
    chosen = select_targets(scene.objects, split_patterns(args.objects), split_patterns(args.bones))

    report = None
    if comparing is not None:
        report = compare.compare(chosen, comparing)
    result = bake.bake(chosen, settings)
    scene.frame_set(scene.frame_current)  # re-evaluate with the baked curves, as the operator does
    if hasattr(scene, "quatcurve"):
        bake_ops.store_result(scene.quatcurve, result)
    if report is not None and hasattr(scene, "quatcurve_compare"):
        compare_ops.store_result(scene.quatcurve_compare, report)

    print("quatcurve %s (Blender %s): %s, frames %g..%g step %g, %s → %s" % (
        native.require().__version__, bpy.app.version_string, settings.method, result.frame_start, result.frame_end, settings.step,
        os.path.basename(source), "in place" if args.in_place else output))
    for line in result.lines():
        print("  " + line)
    print("total: " + result.summary())
    if report is not None:  # the plots as PNG files, then packed from them into the .blend saved next
        compare.save_plots(report, report_file)
    save_atomically(output)
    print("saved %s" % output)
    if report is not None:
        path, pngs = compare.write_report(report, report_file)
        print("compare: %s; wrote %s and %d plot%s" % (report.summary(), path, len(pngs),
                                                        "" if len(pngs) == 1 else "s"))
    return EXIT_OK


def run_fit(args):
    """--fit: the same checks and output handling as a bake; the work is fit.fit."""
    settings = fit_settings(args)
    source = input_path(args)
    output = output_path(args, source)
    native.require()
    open_input(source)
    registered = register_addon()
    try:
        return fit_and_save(args, settings, source, output)
    finally:
        if registered:
            addon.unregister()


def fit_and_save(args, settings, source, output):
    scene = bpy.context.scene
    chosen = select_targets(scene.objects, split_patterns(args.objects), split_patterns(args.bones))
    result = fit.fit(chosen, settings)
    scene.frame_set(scene.frame_current)  # re-evaluate with the fitted curves, as the operator does
    if hasattr(scene, "quatcurve_fit"):
        scene.quatcurve_fit.last_summary = result.summary()
        scene.quatcurve_fit.last_lines = "\n".join(result.lines())
    print("quatcurve %s (Blender %s): fit %s, tolerance %g°, %d subframes, %s → %s" % (
        native.require().__version__, bpy.app.version_string, settings.method, settings.tolerance,
        settings.subframes, os.path.basename(source), "in place" if args.in_place else output))
    for line in result.lines():
        print("  " + line)
    print("total: " + result.summary())
    save_atomically(output)
    print("saved %s" % output)
    return EXIT_OK


def run_convert(args):
    """--convert MODE: the same checks and output handling as a bake; the work is convert.convert."""
    settings = convert_settings(args)
    source = input_path(args)
    output = output_path(args, source)
    native.require()
    open_input(source)
    registered = register_addon()
    try:
        scene = bpy.context.scene
        chosen = select_targets(scene.objects, split_patterns(args.objects), split_patterns(args.bones))
        result = convert.convert(chosen, settings)
        scene.frame_set(scene.frame_current)  # re-evaluate in the new modes, as the operator does
        print("quatcurve %s (Blender %s): convert to %s, tolerance %g°, %d subframes, %s actions, %s → %s" % (
            native.require().__version__, bpy.app.version_string, settings.rotation_mode, settings.tolerance,
            settings.subframes, settings.actions.lower(), os.path.basename(source),
            "in place" if args.in_place else output))
        for line in result.lines():
            print("  " + line)
        print("total: " + result.summary())
        save_atomically(output)
        print("saved %s" % output)
        return EXIT_OK
    finally:
        if registered:
            addon.unregister()


def run_gltf(args):
    """--gltf: the scene of IN.blend exported by gltf.export (the operator's function)."""
    settings = gltf_settings(args)
    source = input_path(args)
    native.require()
    open_input(source)
    registered = register_addon()
    try:
        with blender_output_silenced():  # the exporter's progress lines
            result = gltf.export(bpy.context.scene, args.gltf, settings)
    finally:
        if registered:
            addon.unregister()
    print("quatcurve %s (Blender %s): glTF, curve %s, tolerance %g°, %d subframes, %s -> %s" % (
        native.require().__version__, bpy.app.version_string, settings.method, settings.tolerance,
        settings.subframes, os.path.basename(source), result.filepath))
    for line in result.lines():
        print("  " + line)
    print("total: " + result.summary())
    return EXIT_OK


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
