"""Orientation trails in the 3D Viewport: how the active object's or pose bone's orientation moves
over its frame range, the way motion paths show location.

For the active target (the active pose bone in Pose mode, the active object otherwise), at its
world position: a small axis tripod every `step` frames and the trail of one axis's tip at every
frame — for Blender's own evaluation of the rotation F-curves and, optionally, for a quatcurve
method through the same keys (native `Curve`, sampled), in different colours. Gimbal arcs, flips and
overshoots show up as bends and loops of the tip trail.

Two parts:
- data (testable in background mode): `compute_local` (the target's local rotations per frame, per
  source, cached in `CACHE` under a signature of the rotation F-curves' keys and the settings),
  `world_frame` (where the target sits now) and `trail_points` (tripod segments and tip points in
  world space);
- drawing (`draw_view3d`, registered with SpaceView3D.draw_handler_add only when Blender has a
  window): gpu polylines.

What "world" means here, kept simple on purpose: the anchor point and the frame the local rotation
turns in (parent chain, armature matrix, rest pose of a bone) are the ones evaluated at the current
frame; only the target's own rotation channels move along the trail. A target whose parents rotate
too shows its own rotation relative to where the parents are now. Delta rotations are not shown.

Colours use only components 0 and 1 (magenta, cyan), which every view transform and the sRGB
encoding leave unchanged, so a screenshot test can find them.
"""

import hashlib
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import bake_ops, cycles, fcurves, fit, native, targets
from .targets import TargetError

AXIS_ITEMS = (
    ("X", "X", "Trail of the local X axis's tip"),
    ("Y", "Y", "Trail of the local Y axis's tip (a bone's length axis)"),
    ("Z", "Z", "Trail of the local Z axis's tip"),
)
AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}

BLENDER = "BLENDER"  # the source name of Blender's own evaluation

# RGBA; tripod axes X, Y, Z per source: Blender's in the usual red/green/blue, the method's pale.
TRAIL_COLORS = {BLENDER: (1.0, 0.0, 1.0, 1.0), "METHOD": (0.0, 1.0, 1.0, 1.0)}
TRIPOD_COLORS = {
    BLENDER: ((0.95, 0.2, 0.2, 1.0), (0.3, 0.85, 0.2, 1.0), (0.25, 0.45, 1.0, 1.0)),
    "METHOD": ((1.0, 0.65, 0.65, 0.9), (0.7, 1.0, 0.65, 0.9), (0.65, 0.8, 1.0, 0.9)),
}


def trail_properties():
    """The trail settings as property definitions (scene.quatcurve_trails)."""
    P = bpy.props
    return {
        "show": P.BoolProperty(
            name="Orientation Trails", default=False, update=_redraw,
            description="Draw how the active object or pose bone turns over its frames in the 3D Viewport, as "
                        "motion paths draw where it moves (magenta: Blender's playback)"),
        "show_method": P.BoolProperty(
            name="Compare Method", default=True, update=_redraw,
            description="Also draw how the chosen method would turn through the same keys, in cyan, beside "
                        "Blender's playback"),
        "method": P.EnumProperty(
            name="Method", items=bake_ops.METHOD_ITEMS, default="SLERP", update=_redraw,
            description="The method drawn in cyan beside Blender's playback"),
        "axis": P.EnumProperty(name="Axis", items=AXIS_ITEMS, default="X", update=_redraw,
                               description="The local axis whose tip leaves the trail"),
        "step": P.IntProperty(name="Tripod Every", default=4, min=1, soft_max=50, update=_redraw,
                              description="Draw the object's or bone's axes every this many frames, in frames"),
        "size": P.FloatProperty(name="Size", default=1.0, min=0.0, soft_min=0.01, soft_max=10.0,
                                subtype="DISTANCE", update=_redraw,
                                description="Length of the tripod axes and of the trail's axis, in scene units"),
        "use_scene_range": P.BoolProperty(
            name="Scene Range", default=False, update=_redraw,
            description="Draw over the scene's frame range (off: from the first to the last rotation key)"),
    }


def _redraw(self, context):
    for window in getattr(context.window_manager, "windows", ()):
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


class QuatCurveTrailSettings(bpy.types.PropertyGroup):
    """scene.quatcurve_trails: what the orientation trails show."""
    __annotations__ = trail_properties()


# ---- data -----------------------------------------------------------------------------------------

def active_target(context):
    """The target the trails follow: the active pose bone of an armature in Pose mode, else the
    active object; None without an active object."""
    view_layer = getattr(context, "view_layer", None)
    obj = view_layer.objects.active if view_layer is not None else None
    if obj is None:
        return None
    if obj.type == "ARMATURE" and obj.mode == "POSE" and obj.data.bones.active is not None:
        return targets.Target(obj, obj.data.bones.active.name)
    return targets.Target(obj)


@dataclass(eq=False)
class LocalTrail:
    """A target's local rotation (w, x, y, z) at every frame of `frames` (N,), per source name
    (BLENDER, and the method's name when asked for); `error` instead when the target has none."""
    name: str
    frames: np.ndarray = None
    quats: dict = field(default_factory=dict)
    error: str = ""
    signature: str = ""


def settings_key(settings, scene):
    """The settings that change the local trail (not size, axis, step: those only change drawing)."""
    method = settings.method if settings.show_method else None
    frame_range = (scene.frame_start, scene.frame_end) if settings.use_scene_range else None
    return method, frame_range


def key_signature(target):
    """A digest of what Blender's evaluation of the target's rotation depends on: rotation mode, the
    action, and every key, handle, interpolation and modifier of its rotation F-curves."""
    h = hashlib.sha256()
    owner = target.owner
    mode = owner.rotation_mode
    prop, count = fcurves.rotation_property(mode)
    action = fcurves.active_action(target.id_data)
    h.update(("%s %s %s\n" % (target.name, mode, action.name if action else "")).encode())
    channels = fcurves.Channels.of(target.id_data)
    found = channels.find_all(target.data_path(prop), count) if channels is not None else [None] * count
    current = getattr(owner, prop)
    for i, fcurve in enumerate(found):
        if fcurve is not None and fcurves.key_count(fcurve):
            fcurves.fcurve_digest(fcurve, h)
        else:  # an unkeyed channel holds its current value (a keyed one's changes every frame)
            h.update(("[%d]=%r\n" % (i, current[i])).encode())
    return h.hexdigest()


def compute_local(target, method=None, frame_range=None):
    """LocalTrail of `target`: Blender's evaluation of its rotation channels (active action; NLA
    strips are not evaluated here, since that would move the scene's frame) at every whole frame of
    its keyed range (or `frame_range` (start, end)), and `method`'s native curve through the same
    keys sampled there. A loop (cycles.py) draws one period, its first key to its last, whatever the
    range: every other period is the same path; the method's curve is closed (cyclic=True)."""
    trail = LocalTrail(target.name)
    action = fcurves.active_action(target.id_data)
    try:
        keys = fit.source_keys(target, action=action)
        loop = cycles.loop_of(target, action)
    except (TargetError, RuntimeError) as error:
        trail.error = str(error)
        return trail
    qc = native.require()
    start, end = frame_range if frame_range is not None else (keys.frames[0], keys.frames[-1])
    if loop is not None:
        start, end = loop.start, loop.end
    frames = np.asarray(qc.step_frames(float(start), float(end), 1.0), dtype=np.float64)
    trail.frames = frames
    try:
        trail.quats[BLENDER] = targets.playback(target, action=action).quats(frames)
        if method:
            trail.quats[method] = np.asarray(keys.curve(method, **({"cyclic": True} if loop else {})).sample(frames))
    except (TargetError, ValueError) as error:
        trail.error = str(error)
    return trail


class TrailCache:
    """LocalTrails by target name. An entry is reused while its settings match and, once something
    changed in the scene (`mark_dirty`, from a depsgraph_update_post handler), while its key
    signature still matches; `hits` and `computed` count how it went."""

    def __init__(self):
        self.entries = {}
        self.hits = 0
        self.computed = 0

    def mark_dirty(self):
        for entry in self.entries.values():
            entry["dirty"] = True

    def clear(self):
        self.entries.clear()

    def get(self, target, method=None, frame_range=None):
        key = (method, frame_range)
        entry = self.entries.get(target.name)
        if entry is not None and entry["key"] == key:
            if not entry["dirty"]:
                self.hits += 1
                return entry["trail"]
            signature = key_signature(target)
            if signature == entry["trail"].signature:
                entry["dirty"] = False
                self.hits += 1
                return entry["trail"]
        else:
            signature = key_signature(target)
        trail = compute_local(target, method, frame_range)
        trail.signature = signature
        self.entries[target.name] = {"key": key, "trail": trail, "dirty": False}
        self.computed += 1
        return trail


CACHE = TrailCache()


def world_frame(target):
    """(origin (3,), basis (3, 3)) at the current frame: the target's world position (a bone's
    head) and the world matrix of the frame its rotation channels turn in (parent chain, armature,
    a bone's rest pose; scale kept, removed later by normalizing the axes)."""
    obj = target.object
    world = np.array(obj.matrix_world, dtype=np.float64)
    if target.bone is None:
        local = np.array(obj.matrix_basis, dtype=np.float64)
        parent = world @ _safe_inverse(local)
        return world[:3, 3].copy(), parent[:3, :3]
    pose_bone = obj.pose.bones[target.bone]
    pose = np.array(pose_bone.matrix, dtype=np.float64)              # armature space, evaluated
    parent = world @ pose @ _safe_inverse(np.array(pose_bone.matrix_basis, dtype=np.float64))
    head = world @ np.append(np.array(pose_bone.head, dtype=np.float64), 1.0)
    return head[:3] / head[3], parent[:3, :3]


def _safe_inverse(matrix):
    try:
        return np.linalg.inv(matrix)
    except np.linalg.LinAlgError:  # zero scale: the rotation is undefined; show it unscaled
        return np.linalg.pinv(matrix)


@dataclass(eq=False)
class TrailPoints:
    """World-space drawing data of one source: `origin` (3,) where the tripods stand; `tips` (N, 3)
    the chosen axis's tip at every frame; `tripod_frames` (M,), `tripods` (M, 3, 3): the tip of each
    axis X, Y, Z at those frames."""
    origin: np.ndarray
    frames: np.ndarray
    tips: np.ndarray
    tripod_frames: np.ndarray
    tripods: np.ndarray


def axis_directions(quats, basis):
    """(N, 3, 3) unit world directions of the local axes (index 1: X, Y, Z) of rotations `quats`
    (N, 4) turning in `basis` (3, 3): columns of basis · R(q), normalized (an axis that scale
    collapses to zero stays zero)."""
    qc = native.require()
    rot = np.asarray(qc.quat_to_matrix(np.asarray(quats, dtype=np.float64)))    # (N, 3, 3)
    dirs = np.swapaxes(basis @ rot, 1, 2)                                        # row i: axis i
    norms = np.linalg.norm(dirs, axis=2, keepdims=True)
    return np.divide(dirs, norms, out=np.zeros_like(dirs), where=norms > 0)


def trail_points(trail, origin, basis, axis="X", size=1.0, step=4):
    """TrailPoints per source of a LocalTrail at (origin, basis) (see world_frame): tips of `axis` at
    every frame, tripods at every `step`-th frame from the first (and the last)."""
    out = {}
    if trail.error or trail.frames is None:
        return out
    n = len(trail.frames)
    picks = np.unique(np.append(np.arange(0, n, max(1, int(step))), n - 1))
    for source, quats in trail.quats.items():
        ends = origin + size * axis_directions(quats, basis)                     # (N, 3, 3)
        out[source] = TrailPoints(np.asarray(origin, dtype=np.float64), trail.frames,
                                  ends[:, AXIS_INDEX[axis]].copy(), trail.frames[picks], ends[picks])
    return out


def current_points(context, settings):
    """(target, LocalTrail, {source: TrailPoints}) for the active target now, or None."""
    target = active_target(context)
    if target is None or not native.available():
        return None
    method, frame_range = settings_key(settings, context.scene)
    trail = CACHE.get(target, method, frame_range)
    origin, basis = world_frame(target)
    return target, trail, trail_points(trail, origin, basis, settings.axis, settings.size, settings.step)


# ---- drawing --------------------------------------------------------------------------------------

_SHADER_NAMES = {"polyline": ("POLYLINE_UNIFORM_COLOR", "3D_POLYLINE_UNIFORM_COLOR"),
                 "uniform": ("UNIFORM_COLOR", "3D_UNIFORM_COLOR")}
_shaders = {}


def builtin_shader(kind):
    """The built-in shader of `kind`: 4.x/5.x know the unprefixed names only, 3.4 the '3D_' ones;
    whichever gpu.shader.from_builtin accepts."""
    if kind not in _shaders:
        import gpu
        for name in _SHADER_NAMES[kind]:
            try:
                _shaders[kind] = (name, gpu.shader.from_builtin(name))
                break
            except (ValueError, TypeError):
                continue
        else:
            raise RuntimeError("no built-in shader among %s" % (_SHADER_NAMES[kind],))
    return _shaders[kind]


def _draw_lines(segments, color, width):
    """Line segments (K, 2, 3) in one colour, `width` pixels wide (polyline shader; plain lines if
    that shader is missing)."""
    if len(segments) == 0:
        return
    import gpu
    from gpu_extras.batch import batch_for_shader
    coords = np.ascontiguousarray(segments.reshape(-1, 3), dtype=np.float32)
    try:
        name, shader = builtin_shader("polyline")
        polyline = True
    except RuntimeError:
        name, shader = builtin_shader("uniform")
        polyline = False
    batch = batch_for_shader(shader, "LINES", {"pos": coords.tolist()})
    shader.bind()
    if polyline:
        viewport = gpu.state.viewport_get()
        shader.uniform_float("viewportSize", (viewport[2], viewport[3]))
        shader.uniform_float("lineWidth", width)
    shader.uniform_float("color", color)
    batch.draw(shader)


def _polyline(points):
    """(N, 3) points → (N-1, 2, 3) segments."""
    return np.stack([points[:-1], points[1:]], axis=1) if len(points) > 1 else np.empty((0, 2, 3))


def draw_view3d():
    """The POST_VIEW draw callback: the active target's trails, drawn over the scene."""
    context = bpy.context
    settings = getattr(context.scene, "quatcurve_trails", None)
    if settings is None or not settings.show:
        return
    try:
        found = current_points(context, settings)
    except Exception as error:  # never break the viewport's drawing; say it once per error
        _report_once(error)
        return
    if not found:
        return
    import gpu
    gpu.state.blend_set("ALPHA")
    gpu.state.depth_test_set("NONE")
    try:
        # Tripods first, then the trails over them: Blender's wider, the method's on top, so both
        # show where they coincide.
        ordered = sorted(found[2].items(), key=lambda kv: kv[0] != BLENDER)
        for source, points in ordered:
            kind = BLENDER if source == BLENDER else "METHOD"
            for i in range(3):
                tips = points.tripods[:, i]
                segments = np.stack([np.broadcast_to(points.origin, tips.shape), tips], axis=1)
                _draw_lines(segments, TRIPOD_COLORS[kind][i], 1.5)
        for source, points in ordered:
            kind = BLENDER if source == BLENDER else "METHOD"
            _draw_lines(_polyline(points.tips), TRAIL_COLORS[kind], 5.0 if kind == BLENDER else 2.0)
    finally:
        gpu.state.blend_set("NONE")


_reported = set()


def _report_once(error):
    text = "%s: %s" % (type(error).__name__, error)
    if text not in _reported:
        _reported.add(text)
        print("quatcurve trails: " + text)


# ---- handlers -------------------------------------------------------------------------------------

_draw_handles = []


@bpy.app.handlers.persistent  # kept across file loads (read_factory_settings, open)
def _on_depsgraph_update(scene, depsgraph=None):
    """Something changed (keys, rotation mode, a new file): every cached trail checks its signature
    before it is used again."""
    CACHE.mark_dirty()


def draw_handlers():
    """The draw handlers this module has added (none in background mode)."""
    return list(_draw_handles)


_classes = (QuatCurveTrailSettings,)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.quatcurve_trails = bpy.props.PointerProperty(type=QuatCurveTrailSettings)
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph_update)
    if not bpy.app.background:  # no window, nothing to draw into
        _draw_handles.append(bpy.types.SpaceView3D.draw_handler_add(draw_view3d, (), "WINDOW", "POST_VIEW"))


def unregister():
    while _draw_handles:
        bpy.types.SpaceView3D.draw_handler_remove(_draw_handles.pop(), "WINDOW")
    if _on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_on_depsgraph_update)
    CACHE.clear()
    _shaders.clear()
    del bpy.types.Scene.quatcurve_trails
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
