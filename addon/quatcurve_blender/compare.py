"""Compare: what each interpolation method does to a rotation, side by side with what Blender itself
does with the same keys — in numbers (native metrics), a plot, and a JSON report.

Plain functions, no operator state: the `quatcurve.compare` operator, the CLI and scripts call them.

    found = compare.gather_targets(bpy.context)       # or [targets.Target(obj), targets.Target(rig, "Bone")]
    report = compare.compare(found, compare.CompareSettings(subframes=4))
    compare.write_report(report, "/tmp/report.json")  # the JSON and one PNG per target beside it
    compare.make_images(report)                       # the plots as image datablocks
    print("\\n".join(report.table_lines()))

Sources, per target, sampled over its keyed range every 1/subframes frame (key frames always
included):
- BLENDER: Blender's own evaluation of the target's current rotation curves (its rotation mode,
  interpolation, handles and F-curve modifiers as they are).
- BLENDER_EULER_<ORDER>: Blender's Euler mode with the same keys — the target's order, or all six
  on request: the key orientations as Euler keys (the target's own values when it is keyed in that
  order; otherwise converted as Blender's Quaternion.to_euler converts them, each compatible with
  the previous key), written with Blender's default key type
  (auto-clamped Bezier) into a scratch action and evaluated by Blender.
- BLENDER_QUATERNION: Blender's quaternion mode with the same keys, likewise (w, x, y, z keys; the
  target's own values when it is keyed in quaternion mode, flips included; otherwise converted and
  hemisphere-continuous), normalized after evaluation as Blender does.
- The engine's methods SLERP, SQUAD, CATMULL_ROM, TCB, SPLINE_C2, NLERP through the same keys
  (Euler keys through Curve.from_euler, so turns beyond 180° survive).

Metrics (native, `quatcurve.path_metrics`), reported in degrees: deviation from the SLERP path (max,
mean), the angular speed profile (from consecutive samples) and its max/min ratio per segment, path
length against the sum of key-to-key geodesic angles, the largest jump of angular velocity and
acceleration at keys; for Euler sources the closest approach to gimbal lock and its frames.

Compare never changes animation data: Blender's modes are evaluated in scratch actions that are
removed afterwards (fcurves.scratch_channels); the user's actions are only read.
"""

import json
import math
import os
import re
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import fcurves, native, plot, targets
from .targets import TargetError

ENGINE_METHODS = ("SLERP", "SQUAD", "CATMULL_ROM", "TCB", "SPLINE_C2", "NLERP")
REFERENCE_METHOD = "SLERP"
SOURCE_BLENDER = "BLENDER"
SOURCE_BLENDER_QUATERNION = "BLENDER_QUATERNION"
KEY_INTERPOLATIONS = ("BEZIER", "LINEAR")
MAX_SAMPLES = 2_000_000  # per target; refused before sampling
REPORT_FORMAT = "quatcurve-compare"
REPORT_VERSION = 1

# A method counts as smooth through the keys (for the recommendation) when its largest angular
# velocity jump at a key is below this fraction of the path's mean angular speed.
SMOOTH_JUMP_FRACTION = 0.1


def euler_source(order):
    """Source name of Blender's Euler mode in `order`: 'BLENDER_EULER_XYZ', …"""
    return "BLENDER_EULER_" + order


class CompareError(TargetError):
    """A comparison that cannot be done; the message names the target. Nothing has been changed."""


# ---- settings -------------------------------------------------------------------------------------

@dataclass
class CompareSettings:
    subframes: int = 1                 # samples per frame (1: every frame)
    all_euler_orders: bool = False     # Blender's Euler mode in all six orders (default: the target's
                                       # order; XYZ when the target is not in an Euler mode)
    key_interpolation: str = "BEZIER"  # keys of the scratch Blender-mode curves: BEZIER (auto-clamped,
                                       # Blender's default for new keys) or LINEAR
    methods: tuple = ENGINE_METHODS    # engine methods besides the SLERP reference
    tension: float = 0.0               # TCB options
    continuity: float = 0.0
    bias: float = 0.0
    gimbal_tolerance: float = 0.5      # degrees: frames this close to the closest approach are listed

    def curve_options(self, method):
        if method == "TCB":
            return {"tension": self.tension, "continuity": self.continuity, "bias": self.bias}
        return {}

    def to_json(self):
        return {"subframes": self.subframes, "all_euler_orders": self.all_euler_orders,
                "key_interpolation": self.key_interpolation, "methods": list(self.methods),
                "tension": self.tension, "continuity": self.continuity, "bias": self.bias,
                "gimbal_tolerance_deg": self.gimbal_tolerance}


def check_settings(settings):
    if not (isinstance(settings.subframes, int) and 1 <= settings.subframes <= 1000):
        raise CompareError("subframes %r: must be a whole number from 1 to 1000" % (settings.subframes,))
    if settings.key_interpolation not in KEY_INTERPOLATIONS:
        raise CompareError("key interpolation %r: expected one of %s"
                           % (settings.key_interpolation, ", ".join(KEY_INTERPOLATIONS)))
    unknown = [m for m in settings.methods if m not in ENGINE_METHODS]
    if unknown:
        raise CompareError("method %r: unknown (expected some of %s)" % (unknown[0], ", ".join(ENGINE_METHODS)))
    if not (settings.gimbal_tolerance >= 0):
        raise CompareError("gimbal tolerance %r: must be 0 or more degrees" % (settings.gimbal_tolerance,))


# ---- targets --------------------------------------------------------------------------------------

def gather_targets(context):
    """The selection (selected pose bones in Pose mode, selected objects otherwise), as bake does."""
    try:
        return targets.gather_targets(context, verb="compare")
    except TargetError as error:
        raise CompareError(str(error)) from None


def sample_frames(key_frames, subframes):
    """Frames from the first to the last key every 1/subframes frame, plus every key frame; grid
    points within 1e-4 frames of a key give way to the key (so no sampling interval is tiny).
    Native quatcurve.sample_frames, after refusing more than MAX_SAMPLES samples."""
    key_frames = np.asarray(key_frames, dtype=np.float64)
    first, last = float(key_frames[0]), float(key_frames[-1])
    count = int(math.floor((last - first) * subframes + 1e-9)) + 1
    if count + len(key_frames) > MAX_SAMPLES:
        raise CompareError("%s frames at %d samples per frame: more than %s samples"
                           % ("%g..%g" % (first, last), subframes, f"{MAX_SAMPLES:,}"))
    return native.require().sample_frames(key_frames, subframes)


# ---- results ------------------------------------------------------------------------------------------

@dataclass(eq=False)
class SourceResult:
    """One source's path and metrics. kind: 'blender' (current curves), 'blender_euler',
    'blender_quaternion' (Blender's modes in a scratch action) or 'engine'."""
    name: str
    kind: str
    quats: np.ndarray
    metrics: dict                     # quatcurve.path_metrics (radians, frames)
    euler_order: str = None           # for Euler sources
    gimbal: tuple = None              # (closest distance in radians, frames) for Euler sources

    def to_json(self):
        m = self.metrics
        out = {
            "kind": self.kind,
            "max_deviation_deg": _deg(m["max_deviation"]),
            "max_deviation_frame": _num(m["max_deviation_time"]),
            "mean_deviation_deg": _deg(m["mean_deviation"]),
            "speed_ratio": _num(m["speed_ratio"]),
            "segment_speed_ratios": [_num(r) for r in m["segment_speed_ratios"]],
            "path_length_deg": _deg(m["path_length"]),
            "key_path_length_deg": _deg(m["key_path_length"]),
            "path_length_ratio": _num(m["path_length_ratio"]),
            "max_velocity_jump_deg_per_frame": _deg(m["max_velocity_jump"]),
            "max_velocity_jump_frame": _num(m["max_velocity_jump_time"]),
            "max_acceleration_jump_deg_per_frame2": _deg(m["max_acceleration_jump"]),
            "max_acceleration_jump_frame": _num(m["max_acceleration_jump_time"]),
            "gimbal": None,
        }
        if self.gimbal is not None:
            out["gimbal"] = {"order": self.euler_order, "closest_deg": _deg(self.gimbal[0]),
                             "frames": [_num(f) for f in self.gimbal[1]]}
        return out


@dataclass(eq=False)
class TargetComparison:
    name: str
    rotation_mode: str
    key_frames: np.ndarray
    frames: np.ndarray                # sample frames
    subframes: int
    sources: dict                     # source name → SourceResult, in display order
    euler_orders: dict = field(default_factory=dict)  # order → (closest gimbal distance rad, frames)
    recommendation: dict = field(default_factory=dict)
    plot_file: str = None             # set by write_report
    image_name: str = None            # set by make_images
    _pixels: np.ndarray = None

    def table_rows(self):
        """[(source, max deviation °, speed ratio, path length °)] as display strings."""
        rows = []
        for name, s in self.sources.items():
            m = s.metrics
            rows.append((name, "%.2f°" % math.degrees(m["max_deviation"]), _ratio_text(m["speed_ratio"]),
                         "%.1f°" % math.degrees(m["path_length"])))
        return rows

    def plot_series(self):
        """The plot's series: speed in °/frame at interval midpoints, deviation in ° per sample."""
        mid = 0.5 * (self.frames[1:] + self.frames[:-1])
        return [{"name": name, "speed_frames": mid, "speed": np.degrees(s.metrics["speeds"]),
                 "frames": self.frames, "deviation": np.degrees(s.metrics["deviation"])}
                for name, s in self.sources.items()]

    def render_plot(self):
        """RGBA pixels (plot.HEIGHT, plot.WIDTH, 4) of this target's comparison plot (drawn once)."""
        if self._pixels is None:
            self._pixels = self._render()
        return self._pixels

    def _render(self):
        step = "every frame" if self.subframes == 1 else "every 1/%d frame" % self.subframes
        subtitle = "%s, keys at %s, sampled %s" % (self.rotation_mode, _frames_text(self.key_frames), step)
        return plot.render_comparison(self.name, self.plot_series(), key_frames=self.key_frames,
                                      subtitle=subtitle)

    def to_json(self):
        step = 1.0 / self.subframes
        return {
            "name": self.name,
            "rotation_mode": self.rotation_mode,
            "frames": {"start": _num(self.frames[0]), "end": _num(self.frames[-1]), "step": step,
                       "count": int(len(self.frames))},
            "key_frames": [_num(f) for f in self.key_frames],
            "reference": REFERENCE_METHOD,
            "sources": {name: s.to_json() for name, s in self.sources.items()},
            "euler_orders": {order: {"closest_gimbal_deg": _deg(d), "frames": [_num(f) for f in frames]}
                             for order, (d, frames) in self.euler_orders.items()},
            "recommendation": dict(self.recommendation),
            "plot": self.plot_file,
        }


@dataclass(eq=False)
class CompareReport:
    settings: CompareSettings
    targets: list = field(default_factory=list)
    seconds: float = 0.0

    def to_json(self):
        return {
            "format": REPORT_FORMAT,
            "version": REPORT_VERSION,
            "blender_version": bpy.app.version_string,
            "quatcurve_version": native.require().__version__,
            "settings": self.settings.to_json(),
            "seconds": round(self.seconds, 3),
            "targets": [t.to_json() for t in self.targets],
        }

    def table_lines(self):
        """The comparison table as text: per target a header, one row per source, the recommendation."""
        lines = []
        for t in self.targets:
            lines.append("%s (%s, keys %s)" % (t.name, t.rotation_mode, _frames_text(t.key_frames)))
            lines.append("  %-22s %12s %12s %12s" % ("source", "max dev", "speed ratio", "path length"))
            for row in t.table_rows():
                lines.append("  %-22s %12s %12s %12s" % row)
            lines.append("  -> " + t.recommendation.get("text", ""))
        return lines

    def summary(self):
        return "%d target%s, %d sources, %.2f s" % (
            len(self.targets), "" if len(self.targets) == 1 else "s",
            sum(len(t.sources) for t in self.targets), self.seconds)


def _deg(x):
    return _num(math.degrees(x)) if math.isfinite(x) else None


def _num(x):
    """A JSON number (float), None for inf/NaN (JSON has neither; null reads as 'unbounded')."""
    x = float(x)
    return x if math.isfinite(x) else None


# Speed ratios above this mean the path comes to a stop inside a segment — as Blender's auto-clamped
# Bezier keys do at the first and last key (flat handles). The sampled ratio of a true stop is finite
# (the speed at the key is extrapolated from the samples beside it) and grows with the sampling rate,
# so the table says "stops" instead of a figure that depends on it.
STOP_RATIO = 100.0


def _ratio_text(r):
    return "%.3f" % r if r < STOP_RATIO else "stops"


def _frames_text(frames):
    frames = [("%g" % f) for f in frames]
    return ", ".join(frames) if len(frames) <= 6 else "%s ... %s (%d)" % (frames[0], frames[-1], len(frames))  # the plot font has no "…"


# ---- Blender's modes in a scratch action ----------------------------------------------------------------

def evaluate_in_scratch(prop, key_frames, key_values, frames, interpolation="BEZIER"):
    """(N, C) values of C channels keyed (key_frames, key_values[:, c]) with `interpolation` — BEZIER
    with Blender's default auto-clamped handles, or LINEAR — as Blender evaluates them at `frames`
    (fcurves.evaluate_scratch_keys: a scratch action, removed before returning)."""
    return fcurves.evaluate_scratch_keys(prop, key_frames, key_values, frames, interpolation)


def euler_keys(keys, key_quats, order):
    """Euler key values (K, 3) in `order` for the keys: the target's own values when it is keyed in
    that order (so turns beyond 180° survive), else the key orientations converted as Blender
    converts them — the first Quaternion.to_euler(order), each next to_euler(order, previous)."""
    if keys.mode == order:
        return np.asarray(keys.values, dtype=np.float64)
    return native.require().quats_to_channels(key_quats, order, euler="blender")


def quaternion_keys(keys, key_quats):
    """Quaternion key values (K, 4): the target's own when keyed in quaternion mode (as stored: sign
    flips included, which Blender interpolates through), else hemisphere-continuous conversions."""
    if keys.mode == "QUATERNION":
        return np.asarray(keys.values, dtype=np.float64)
    return native.require().quats_to_channels(key_quats, "QUATERNION")


# ---- one target --------------------------------------------------------------------------------------

def compare_target(target, settings):
    """TargetComparison of one target (see the module doc). Raises CompareError."""
    qc = native.require()
    try:
        keys = targets.read_rotation_keys(target)
    except TargetError as error:
        raise CompareError(str(error)) from None
    if len(keys.frames) < 2:
        raise CompareError("%s: one rotation key (frame %g): nothing to compare" % (target.name, keys.frames[0]))
    frames = sample_frames(keys.frames, settings.subframes)
    try:
        key_quats = keys.quats()
        current = keys.quats(frames)
    except TargetError as error:
        raise CompareError(str(error)) from None
    paths = {}  # name → (kind, quats, euler order, euler angles)
    paths[SOURCE_BLENDER] = ("blender", current, keys.mode if keys.is_euler else None,
                             keys.evaluate(frames) if keys.is_euler else None)

    orders = fcurves.EULER_ORDERS if settings.all_euler_orders else (keys.mode if keys.is_euler else "XYZ",)
    for order in orders:
        values = euler_keys(keys, key_quats, order)
        angles = evaluate_in_scratch("rotation_euler", keys.frames, values, frames, settings.key_interpolation)
        paths[euler_source(order)] = ("blender_euler", qc.channels_to_quats(angles, order), order, angles)
    values = evaluate_in_scratch("rotation_quaternion", keys.frames, quaternion_keys(keys, key_quats), frames,
                                 settings.key_interpolation)
    try:
        quats = targets.channels_to_quats("QUATERNION", values, "%s (Blender quaternion mode)" % target.name,
                                          frames)
    except TargetError as error:
        raise CompareError(str(error)) from None
    paths[SOURCE_BLENDER_QUATERNION] = ("blender_quaternion", quats, None, None)

    methods = [REFERENCE_METHOD] + [m for m in settings.methods if m != REFERENCE_METHOD]
    for method in methods:
        try:
            curve = keys.curve(method, **settings.curve_options(method))
            paths[method] = ("engine", np.asarray(curve.sample(frames), dtype=np.float64), None, None)
        except ValueError as error:
            raise CompareError("%s: %s: %s" % (target.name, method, error)) from None
    reference = paths[REFERENCE_METHOD][1]

    tolerance = math.radians(settings.gimbal_tolerance)
    sources = {}
    for name, (kind, quats, order, angles) in paths.items():
        metrics = qc.path_metrics(frames, quats, keys.frames, reference, key_quats=key_quats)
        result = SourceResult(name, kind, quats, metrics)
        if order is not None:
            distance, where = qc.closest_gimbal_approach(frames, qc.gimbal_distances(angles, order), tolerance)
            result.euler_order, result.gimbal = order, (float(distance), _compress_frames(where))
        sources[name] = result

    comparison = TargetComparison(target.name, keys.mode, np.asarray(keys.frames, dtype=np.float64), frames,
                                  settings.subframes, sources)
    # How close the motion itself (Blender's evaluation) comes to gimbal lock in each order.
    for order in fcurves.EULER_ORDERS:
        distance, where = qc.closest_gimbal_approach(frames, qc.gimbal_distances_from_quats(current, order),
                                                     tolerance)
        comparison.euler_orders[order] = (float(distance), _compress_frames(where))
    comparison.recommendation = recommend(comparison)
    return comparison


def _compress_frames(frames, limit=50):
    """The first `limit` frames (a long stretch near gimbal lock lists its start)."""
    return [float(f) for f in np.asarray(frames)[:limit]]


def recommend(comparison):
    """The recommendation for one target:
    - method: among the engine methods that are smooth through the keys (largest angular velocity
      jump below SMOOTH_JUMP_FRACTION of the mean speed), the steadiest speed and smallest deviation
      from SLERP — the smallest sum of the two ranks, ties to the steadier speed;
    - constant_speed_method: the steadiest speed of all engine methods (SLERP is constant within
      segments but usually jumps at keys: its jump is quoted);
    - euler_order: the order whose closest approach to gimbal lock over the motion is farthest."""
    engine = {n: s for n, s in comparison.sources.items() if s.kind == "engine"}
    duration = float(comparison.frames[-1] - comparison.frames[0])
    moving = max((s.metrics["path_length"] for s in engine.values()), default=0.0)
    mean_speed = moving / duration if duration > 0 else 0.0
    smooth = {n: s for n, s in engine.items()
              if s.metrics["max_velocity_jump"] <= SMOOTH_JUMP_FRACTION * mean_speed + 1e-9}
    pool = smooth or engine

    # Values equal to 1e-6 tie (methods that coincide, e.g. every method on two keys); a tie goes to
    # the method listed first in ENGINE_METHODS (SLERP, the simplest).
    def value(n, name):
        return round(comparison.sources[n].metrics[name], 6)

    def ranks(name):  # competition ranking: the number of methods strictly better
        return {n: sum(value(o, name) < value(n, name) for o in pool) for n in pool}

    speed_rank, deviation_rank = ranks("speed_ratio"), ranks("max_deviation")
    listed = ENGINE_METHODS.index
    method = min(pool, key=lambda n: (speed_rank[n] + deviation_rank[n], value(n, "speed_ratio"),
                                      value(n, "max_deviation"), listed(n)))
    steadiest = min(engine, key=lambda n: (value(n, "speed_ratio"), value(n, "max_deviation"), listed(n)))
    order = max(comparison.euler_orders, key=lambda o: comparison.euler_orders[o][0])
    m, s = pool[method].metrics, engine[steadiest].metrics
    text = "%s: speed ratio %s, %.2f° from SLERP%s" % (
        method, _ratio_text(m["speed_ratio"]), math.degrees(m["max_deviation"]),
        "" if method in smooth else " (no method is smooth through these keys)")
    if steadiest != method:
        text += "; steadiest: %s (ratio %s, velocity jumps up to %.2f°/frame at keys)" % (
            steadiest, _ratio_text(s["speed_ratio"]), math.degrees(s["max_velocity_jump"]))
    text += "; Euler order %s stays %.1f° from gimbal lock" % (
        order, math.degrees(comparison.euler_orders[order][0]))
    return {"method": method, "constant_speed_method": steadiest, "euler_order": order, "text": text}


# ---- all targets --------------------------------------------------------------------------------------------

def compare(found, settings=None):
    """CompareReport for `found` (targets.Target). Reads the targets' curves and evaluates scratch
    actions; changes no animation data. Raises CompareError naming the target at fault."""
    settings = settings or CompareSettings()
    check_settings(settings)
    native.require()
    if not found:
        raise CompareError("Nothing to compare: no targets")
    begin = time.perf_counter()
    report = CompareReport(settings)
    for target in found:
        report.targets.append(compare_target(target, settings))
    report.seconds = time.perf_counter() - begin
    return report


# ---- output: JSON, PNG, image datablocks ----------------------------------------------------------------------

def plot_path(report_path, target_name):
    """PNG path of a target's plot beside the report: <report without .json>_<target>.png, the target
    name reduced to letters, digits, '-', '_' and '.' ('Armature/Bone' → 'Armature_Bone')."""
    stem = report_path[:-5] if report_path.lower().endswith(".json") else report_path
    return "%s_%s.png" % (stem, re.sub(r"[^A-Za-z0-9_.-]+", "_", target_name))


def write_report(report, report_path):
    """Writes the JSON report at `report_path` and each target's plot as a PNG beside it (see
    plot_path); returns (report_path, [png paths]). The JSON names each target's PNG (file name only,
    relative to the report's folder)."""
    folder = os.path.dirname(os.path.abspath(report_path))
    os.makedirs(folder, exist_ok=True)
    pngs = []
    for t in report.targets:
        path = plot_path(report_path, t.name)
        plot.write_png(path, t.render_plot())
        t.plot_file = os.path.basename(path)
        pngs.append(path)
    data = report.to_json()
    errors = validate(data, REPORT_SCHEMA)
    if errors:  # a bug, not a user error: the report must always match its documented schema
        raise RuntimeError("compare report does not match its schema: " + "; ".join(errors[:5]))
    tmp = report_path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1, allow_nan=False)
        f.write("\n")
    os.replace(tmp, report_path)
    return report_path, pngs


def image_name(target_name):
    return "QuatCurve compare: " + target_name


def make_images(report):
    """One image datablock per target holding its plot (shown in Blender's Image Editor), replaced
    when it already exists; packed and given a fake user, so it is saved with the .blend (an image
    nothing uses is dropped on save). Returns the images."""
    images = []
    for t in report.targets:
        pixels = t.render_plot()
        name = image_name(t.name)
        old = bpy.data.images.get(name)
        if old is not None:
            bpy.data.images.remove(old)
        image = bpy.data.images.new(name, plot.WIDTH, plot.HEIGHT, alpha=True)
        # Blender's rows run bottom to top; its pixels are floats 0..1.
        flat = (pixels[::-1].astype(np.float32) / 255.0).ravel()
        image.pixels.foreach_set(flat)
        image.update()
        image.pack()
        image.use_fake_user = True
        t.image_name = image.name
        images.append(image)
    return images


# ---- the report's schema ------------------------------------------------------------------------------------
# JSON-schema-like: "type" (a JSON type name or a list of them), "properties" + "required" for objects,
# "values" for objects used as maps, "items" for arrays, "enum". README.md documents the same fields.

_NUMBER = {"type": "number"}
_NUMBER_OR_NULL = {"type": ["number", "null"]}
_FRAMES = {"type": "array", "items": _NUMBER}

SOURCE_SCHEMA = {
    "type": "object",
    "required": ["kind", "max_deviation_deg", "max_deviation_frame", "mean_deviation_deg", "speed_ratio",
                 "segment_speed_ratios", "path_length_deg", "key_path_length_deg", "path_length_ratio",
                 "max_velocity_jump_deg_per_frame", "max_velocity_jump_frame",
                 "max_acceleration_jump_deg_per_frame2", "max_acceleration_jump_frame", "gimbal"],
    "properties": {
        "kind": {"type": "string", "enum": ["blender", "blender_euler", "blender_quaternion", "engine"]},
        "max_deviation_deg": _NUMBER,
        "max_deviation_frame": _NUMBER,
        "mean_deviation_deg": _NUMBER,
        "speed_ratio": _NUMBER_OR_NULL,
        "segment_speed_ratios": {"type": "array", "items": _NUMBER_OR_NULL},
        "path_length_deg": _NUMBER,
        "key_path_length_deg": _NUMBER,
        "path_length_ratio": _NUMBER_OR_NULL,
        "max_velocity_jump_deg_per_frame": _NUMBER,
        "max_velocity_jump_frame": _NUMBER,
        "max_acceleration_jump_deg_per_frame2": _NUMBER,
        "max_acceleration_jump_frame": _NUMBER,
        "gimbal": {"type": ["object", "null"], "required": ["order", "closest_deg", "frames"],
                   "properties": {"order": {"type": "string", "enum": list(fcurves.EULER_ORDERS)},
                                  "closest_deg": _NUMBER, "frames": _FRAMES}},
    },
}

TARGET_SCHEMA = {
    "type": "object",
    "required": ["name", "rotation_mode", "frames", "key_frames", "reference", "sources", "euler_orders",
                 "recommendation", "plot"],
    "properties": {
        "name": {"type": "string"},
        "rotation_mode": {"type": "string"},
        "frames": {"type": "object", "required": ["start", "end", "step", "count"],
                   "properties": {"start": _NUMBER, "end": _NUMBER, "step": _NUMBER, "count": {"type": "integer"}}},
        "key_frames": _FRAMES,
        "reference": {"type": "string"},
        "sources": {"type": "object", "values": SOURCE_SCHEMA},
        "euler_orders": {"type": "object", "values": {
            "type": "object", "required": ["closest_gimbal_deg", "frames"],
            "properties": {"closest_gimbal_deg": _NUMBER, "frames": _FRAMES}}},
        "recommendation": {"type": "object", "required": ["method", "constant_speed_method", "euler_order", "text"],
                           "properties": {"method": {"type": "string", "enum": list(ENGINE_METHODS)},
                                          "constant_speed_method": {"type": "string", "enum": list(ENGINE_METHODS)},
                                          "euler_order": {"type": "string", "enum": list(fcurves.EULER_ORDERS)},
                                          "text": {"type": "string"}}},
        "plot": {"type": ["string", "null"]},
    },
}

REPORT_SCHEMA = {
    "type": "object",
    "required": ["format", "version", "blender_version", "quatcurve_version", "settings", "seconds", "targets"],
    "properties": {
        "format": {"type": "string", "enum": [REPORT_FORMAT]},
        "version": {"type": "integer", "enum": [REPORT_VERSION]},
        "blender_version": {"type": "string"},
        "quatcurve_version": {"type": "string"},
        "settings": {"type": "object"},
        "seconds": _NUMBER,
        "targets": {"type": "array", "items": TARGET_SCHEMA},
    },
}

_JSON_TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
}


def validate(value, schema, path="$"):
    """Errors (strings naming the JSON path) of `value` against a schema of the form above; [] if valid."""
    types = schema.get("type")
    if types is not None:
        types = [types] if isinstance(types, str) else types
        if not any(_JSON_TYPES[t](value) for t in types):
            return ["%s: expected %s, got %s" % (path, " or ".join(types), type(value).__name__)]
    if value is None:
        return []
    errors = []
    if "enum" in schema and value not in schema["enum"]:
        errors.append("%s: %r is not one of %s" % (path, value, schema["enum"]))
    if isinstance(value, dict):
        for key in schema.get("required", ()):
            if key not in value:
                errors.append("%s: missing %r" % (path, key))
        for key, sub in schema.get("properties", {}).items():
            if key in value:
                errors += validate(value[key], sub, "%s.%s" % (path, key))
        if "values" in schema:
            for key, item in value.items():
                errors += validate(item, schema["values"], "%s[%r]" % (path, key))
    if isinstance(value, list) and "items" in schema:
        for i, item in enumerate(value):
            errors += validate(item, schema["items"], "%s[%d]" % (path, i))
    return errors
