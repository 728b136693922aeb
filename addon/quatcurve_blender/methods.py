"""The interpolation methods, as the native module defines them: their names (`quatcurve.METHODS`)
and the options each takes (`quatcurve.METHOD_OPTIONS`). Every task, the operators, the panel and the
CLI take their method lists and options from here; this module adds only what the UI says of each.

    methods.CURVE_METHODS                     # what fit, compare and trails offer
    methods.options("TCB", settings)          # {'tension': …, 'continuity': …, 'bias': …, 'clamped': …}

The add-on registers without the native module (the panel then says why it is missing): the lists
then hold SLERP alone and every operator refuses with the reason (native.require).
"""

from . import native

_module = native.module
# Every method, in the native order: the bake offers them all.
ALL = tuple(_module.METHODS) if _module is not None else ("SLERP",)
# Blender's own per-channel LINEAR interpolations (each Euler angle; the four quaternion components):
# the bake can write them, but they are what the curve methods replace, so fit, compare and trails do
# not offer them as curves.
CHANNEL_METHODS = ("EULER", "QUAT_COMPONENTS")
CURVE_METHODS = tuple(m for m in ALL if m not in CHANNEL_METHODS)
# Per-key options, given by key arrays (the fit's ease and turns records), not by settings.
PER_KEY_OPTIONS = ("ease_in", "ease_out", "turns")

# What the UI says of each method: (label, tooltip).
_TEXT = {
    "EULER": ("Euler (linear angles)", "Each Euler angle linear between keys: Blender's Euler mode with "
                                       "LINEAR keys"),
    "QUAT_COMPONENTS": ("Quaternion components", "w, x, y, z linear then normalized, no hemisphere fix: "
                                                 "Blender's quaternion mode with LINEAR keys"),
    "NLERP": ("Nlerp", "Normalized linear interpolation of quaternions, the shorter way between keys"),
    "SLERP": ("Slerp", "Constant angular speed along the arc between keys (Maya's Quaternion Slerp; glTF's "
                       "LINEAR rotation)"),
    "SQUAD": ("Squad", "Smooth spherical quadrangle through the keys (Maya's Quaternion Cubic)"),
    "CATMULL_ROM": ("Catmull-Rom", "Smooth spherical spline through the keys"),
    "TCB": ("TCB", "Kochanek-Bartels with tension, continuity and bias (3ds Max's TCB rotation)"),
    "SPLINE_C2": ("C2 Spline", "Continuous angular velocity and acceleration (may overshoot on uneven key "
                               "spacing)"),
}


def label(method):
    """What the menus call `method`: 'C2 Spline' for SPLINE_C2. Result lines and reports name methods
    this way too."""
    return _TEXT.get(method, (method.replace("_", " ").title(), ""))[0]


def label_and_id(method):
    """'C2 Spline (SPLINE_C2)': the label and the identifier a script or the CLI's --method takes, for
    the line of a result that names the method once (a run's header, a fit's summary); the label alone
    where the two are the same ('TCB')."""
    name = label(method)
    return name if name == method else "%s (%s)" % (name, method)


def enum_items(methods):
    """EnumProperty items (identifier, label, tooltip) of `methods`."""
    return tuple((m, label(m), _TEXT.get(m, ("", ""))[1]) for m in methods)


def option_names(method):
    """The settings-level options `method` takes (the native list without the per-key ease)."""
    names = _module.METHOD_OPTIONS.get(method, ()) if _module is not None else ()
    return tuple(n for n in names if n not in PER_KEY_OPTIONS)


def options(method, settings):
    """Keyword options of quatcurve.Curve for `method` from `settings` (any object with attributes of
    the options' names: a task's settings, an operator, a scene property group): each option the
    method takes and the settings have; the others keep the native defaults."""
    out = {}
    for name in option_names(method):
        if hasattr(settings, name):
            value = getattr(settings, name)
            out[name] = bool(value) if isinstance(value, bool) else value
    return out


def draw_options(layout, settings):
    """The options of settings.method that the settings hold, one row each (the panel, the redo panel)."""
    for name in option_names(settings.method):
        if hasattr(settings, name):
            layout.prop(settings, name)
