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

Loops (cycles.py: Cycles modifiers on every rotation channel) are compared through the seam: the
seam is a key like the others. One period is sampled (first key to last), and the key metrics
(velocity and acceleration jumps) also see the segment before the seam (the last one, a period
earlier) and the one after it (the first, a period later); the engine's curves are closed
(cyclic=True), Blender's modes are evaluated with a Cycles modifier on the scratch channels (Blender's
cycle-aware auto handles), and the report marks the target cyclic with its period. A Cycles modifier
no task reads as a loop (Mirror, a finite count, …) is refused, naming target, channel and modifier.

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

from . import cycles, fcurves, fit, methods, native, path_rule, plot, targets
from .workers import parallel_imap
from .targets import TargetError

# The curve methods in the order the recommendation prefers them on a tie (recommend): SLERP first
# (the reference), NLERP last (it is SLERP's cheaper approximation).
ENGINE_METHODS = tuple(sorted(methods.CURVE_METHODS, key=lambda m: (m != "SLERP", m == "NLERP",
                                                                   methods.CURVE_METHODS.index(m))))
REFERENCE_METHOD = "SLERP"
SOURCE_BLENDER = "BLENDER"
SOURCE_BLENDER_QUATERNION = "BLENDER_QUATERNION"
KEY_INTERPOLATIONS = ("BEZIER", "LINEAR")
MAX_SAMPLES = 2_000_000  # per target; refused before sampling
REPORT_FORMAT = "quatcurve-compare"
REPORT_VERSION = 1

# The recommendation (see recommend and docs/compare.md):
# smooth at the keys: the largest angular velocity jump at a key is at most this fraction of the mean
# keyed speed (the keyed arcs over the keyed frames);
SMOOTH_JUMP_FRACTION = 0.1
# steady: in every moving key segment the speed ratio is at most this × the ratio the keys ask for;
STEADY_EXCESS = 1.5
# passes the keys / holds: within this many degrees of each key; a segment with a keyed arc this
# small is a hold.
KEY_TOLERANCE_DEG = 0.01
# the keys reverse at a key when the motion turns back by more than this there (a stop is expected).
REVERSAL_DEG = 150.0


# What the menus and reports call each source ("C2 Spline", "Blender Euler XYZ"); the JSON keeps the
# identifiers.
SOURCE_NAMES = dict({method: methods.label(method) for method in methods.ALL},
                    BLENDER="Blender (as keyed)", BLENDER_QUATERNION="Blender Quaternion")


def source_label(source):
    """'Slerp', 'C2 Spline', 'Blender Euler XYZ', 'Blender (as keyed)' for a source identifier."""
    if source.startswith("BLENDER_EULER_"):
        return "Blender Euler " + source[len("BLENDER_EULER_"):]
    return SOURCE_NAMES.get(source, source)


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
        return methods.options(method, self)

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
    segment_paths: np.ndarray = None  # engine methods: (K-1, 2) keyed arc, sampled path (Curve.segment_paths)

    def to_json(self):
        m = self.metrics
        out = {
            "kind": self.kind,
            "max_deviation_deg": _deg(m["max_deviation"]),
            "max_deviation_frame": _num(m["max_deviation_time"]),
            "mean_deviation_deg": _deg(m["mean_deviation"]),
            "speed_ratio": _num(m["speed_ratio"]),
            "segment_speed_ratios": _nums(m["segment_speed_ratios"]),
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
                             "frames": _nums(self.gimbal[1])}
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
    path_rule: list = field(default_factory=list)  # path_rule.PathRuleBreak of the engine methods
    keyed_speed_ratios: np.ndarray = None  # per key segment (keyed_speed_ratios)
    loop: cycles.Loop = None          # a loop (Cycles modifiers): compared through its seam
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
            "key_frames": _nums(self.key_frames),
            "cyclic": self.loop is not None,
            "period": _num(self.loop.period) if self.loop is not None else None,
            "reference": REFERENCE_METHOD,
            "sources": {name: s.to_json() for name, s in self.sources.items()},
            "euler_orders": {order: {"closest_gimbal_deg": _deg(d), "frames": _nums(frames)}
                             for order, (d, frames) in self.euler_orders.items()},
            "keyed_speed_ratios": _nums(self.keyed_speed_ratios),
            "path_rule": [b.to_json() for b in self.path_rule],
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
            lines.append("%s (%s, keys %s%s)" % (t.name, t.rotation_mode, _frames_text(t.key_frames),
                                                 "" if t.loop is None else
                                                 ", a loop: period %g frames, seam at the first and last key"
                                                 % t.loop.period))
            lines.append("  %-22s %12s %12s %12s" % ("source", "max dev", "speed ratio", "path length"))
            for row in t.table_rows():
                lines.append("  %-22s %12s %12s %12s" % ((source_label(row[0]),) + row[1:]))
            for b in t.path_rule:
                lines.append("  path rule: " + b.text())
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


def _nums(values):
    """[_num(x) for x in values], in bulk (a report holds ~100 k of them)."""
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    out = values.tolist()
    if not np.isfinite(values).all():
        out = [x if math.isfinite(x) else None for x in out]
    return out


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

def evaluate_in_scratch(prop, key_frames, key_values, frames, interpolation="BEZIER", cycle=None):
    """(N, C) values of C channels keyed (key_frames, key_values[:, c]) with `interpolation` — BEZIER
    with Blender's default auto-clamped handles, or LINEAR — as Blender evaluates them at `frames`
    (fcurves.evaluate_scratch_keys: a scratch action, removed before returning); `cycle`
    ('REPEAT', 'REPEAT_OFFSET') makes them a loop, as Blender's Cycles modifier does."""
    return fcurves.evaluate_scratch_keys(prop, key_frames, key_values, frames, interpolation, cycle)


@dataclass(frozen=True)
class Seam:
    """Where a loop's seam is measured: `frames`, the period's sample frames with the last key
    segment one period earlier before them and the first one period later after them; `key_frames`,
    the keys with those two neighbours (so the first and last key, the seam, are interior keys);
    `period`: the slice of `frames` that is the period's samples."""
    frames: np.ndarray
    key_frames: np.ndarray
    period: slice


def seam_frames(frames, key_frames):
    """The Seam of a loop sampled at `frames` (first key to last) with keys `key_frames`: the same
    sample grid, wrapped by one period on each side over the segment beside the seam."""
    frames, key_frames = np.asarray(frames, np.float64), np.asarray(key_frames, np.float64)
    period = float(key_frames[-1] - key_frames[0])
    before = frames[frames >= key_frames[-2]] - period   # the last segment, ending at the first key
    after = frames[frames <= key_frames[1]] + period      # the first segment, starting at the last key
    wrapped = np.concatenate([before[:-1], frames, after[1:]])
    keys = np.concatenate([before[:1], key_frames, after[-1:]])
    return Seam(wrapped, keys, slice(len(before) - 1, len(before) - 1 + len(frames)))


def euler_keys(keys, key_quats, order):
    """Euler key values (K, 3) in `order` for the keys: the target's own values when it is keyed in
    that order (so turns beyond 180° survive), else the key orientations converted as Blender
    converts them — the first Quaternion.to_euler(order), each next to_euler(order, previous)."""
    if keys.mode == order:
        return np.asarray(keys.values, dtype=np.float64)
    return native.require().quats_to_channels(key_quats, order, euler="blender")


def euler_cycle(values):
    """The Cycles mode of a loop's Euler keys `values` (K, 3): Repeat when the last key is the first,
    else Repeat with Offset (a wheel, or keys converted from another mode whose seam key lands whole
    turns away), so that each period starts where the last ended, as Blender plays them."""
    return "REPEAT" if np.array_equal(values[0], values[-1]) else "REPEAT_OFFSET"


def quaternion_keys(keys, key_quats):
    """Quaternion key values (K, 4): the target's own when keyed in quaternion mode (as stored: sign
    flips included, which Blender interpolates through), else hemisphere-continuous conversions."""
    if keys.mode == "QUATERNION":
        return np.asarray(keys.values, dtype=np.float64)
    return native.require().quats_to_channels(key_quats, "QUATERNION")


# ---- one target --------------------------------------------------------------------------------------

@dataclass(eq=False)
class _Reading:
    """What a comparison reads from Blender for one target (read_target, main thread): its keys, the
    sample frames, and the paths Blender itself plays (its evaluation, scratch Euler and quaternion
    keys) as (kind, quats, euler order, euler angles)."""
    target: targets.Target
    keys: targets.RotationKeys
    frames: np.ndarray
    key_quats: np.ndarray
    current: np.ndarray
    paths: dict
    loop: cycles.Loop = None   # a loop: the paths are sampled at seam.frames, the period at seam.period
    seam: Seam = None


def read_target(target, settings):
    """The Blender side of a comparison (main thread only): _Reading. Raises CompareError."""
    qc = native.require()
    try:
        keys = fit.source_keys(target)
    except TargetError as error:
        raise CompareError(str(error)) from None
    if len(keys.frames) < 2:
        raise CompareError("%s: one rotation key (frame %g): nothing to compare" % (target.name, keys.frames[0]))
    try:
        loop = cycles.loop_of_keys(target, keys)
    except TargetError as error:
        raise CompareError(str(error)) from None
    frames = sample_frames(keys.frames, settings.subframes)
    seam, cycle = None, False
    if loop is not None:
        seam = seam_frames(frames, keys.frames)
        frames = seam.frames  # every path is sampled through the seam; measure slices the period
        cycle = True
    try:
        played = targets.playback(target)
        key_quats = keys.quats()
        current = played.quats(frames)
    except TargetError as error:
        raise CompareError(str(error)) from None
    paths = {}  # name → (kind, quats, euler order, euler angles)
    paths[SOURCE_BLENDER] = ("blender", current, keys.mode if keys.is_euler else None,
                             played.evaluate(frames) if keys.is_euler else None)

    orders = fcurves.EULER_ORDERS if settings.all_euler_orders else (keys.mode if keys.is_euler else "XYZ",)
    for order in orders:
        values = euler_keys(keys, key_quats, order)
        angles = evaluate_in_scratch("rotation_euler", keys.frames, values, frames, settings.key_interpolation,
                                     euler_cycle(values) if cycle else None)
        paths[euler_source(order)] = ("blender_euler", qc.channels_to_quats(angles, order), order, angles)
    values = evaluate_in_scratch("rotation_quaternion", keys.frames, quaternion_keys(keys, key_quats), frames,
                                 settings.key_interpolation, "REPEAT" if cycle else None)
    try:
        quats = targets.channels_to_quats("QUATERNION", values, "%s (Blender quaternion mode)" % target.name,
                                          frames)
    except TargetError as error:
        raise CompareError(str(error)) from None
    paths[SOURCE_BLENDER_QUATERNION] = ("blender_quaternion", quats, None, None)
    return _Reading(target, keys, frames, key_quats, current, paths, loop, seam)


def measure(reading, settings):
    """The TargetComparison of a _Reading: the engine methods' curves and every path's metrics. Touches
    no Blender data (worker threads run it). Raises CompareError."""
    qc = native.require()
    target, keys, frames, key_quats = reading.target, reading.keys, reading.frames, reading.key_quats
    paths = dict(reading.paths)
    methods = [REFERENCE_METHOD] + [m for m in settings.methods if m != REFERENCE_METHOD]
    cyclic = {"cyclic": True} if reading.loop is not None else {}
    segment_paths, breaks = {}, []
    for method in methods:
        try:
            curve = keys.curve(method, **settings.curve_options(method), **cyclic)
            paths[method] = ("engine", np.asarray(curve.sample(frames), dtype=np.float64), None, None)
            segment_paths[method] = np.asarray(curve.segment_paths(), dtype=np.float64).reshape(-1, 2)
            breaks += path_rule.breaks(curve, keys.frames, target.name, method, segment_paths[method])
        except ValueError as error:
            raise CompareError("%s: %s: %s" % (target.name, methods.label(method), error)) from None
    seam = reading.seam
    period = seam.period if seam is not None else slice(None)
    wrapped = paths
    paths = {name: (kind, quats[period], order, None if angles is None else angles[period])
             for name, (kind, quats, order, angles) in wrapped.items()}
    frames = frames[period]
    reference = paths[REFERENCE_METHOD][1]

    tolerance = math.radians(settings.gimbal_tolerance)
    sources = {}
    for name, (kind, quats, order, angles) in paths.items():
        metrics = qc.path_metrics(frames, quats, keys.frames, reference, key_quats=key_quats)
        if seam is not None:
            seam_jumps(metrics, qc.key_jumps(seam.frames, wrapped[name][1], seam.key_frames), keys.frames)
        result = SourceResult(name, kind, quats, metrics, segment_paths=segment_paths.get(name))
        if order is not None:
            distance, where = qc.closest_gimbal_approach(frames, qc.gimbal_distances(angles, order), tolerance)
            result.euler_order, result.gimbal = order, (float(distance), _compress_frames(where))
        sources[name] = result

    comparison = TargetComparison(target.name, keys.mode, np.asarray(keys.frames, dtype=np.float64), frames,
                                  settings.subframes, sources, path_rule=breaks, loop=reading.loop)
    comparison.keyed_speed_ratios = keyed_speed_ratios(keys.frames, segment_paths[REFERENCE_METHOD][:, 0], key_quats)
    # How close the motion itself (Blender's evaluation) comes to gimbal lock in each order.
    for order in fcurves.EULER_ORDERS:
        distance, where = qc.closest_gimbal_approach(frames, qc.gimbal_distances_from_quats(paths[SOURCE_BLENDER][1], order),
                                                     tolerance)
        comparison.euler_orders[order] = (float(distance), _compress_frames(where))
    comparison.recommendation = recommend(comparison)
    return comparison


def seam_jumps(metrics, jumps, key_frames):
    """Puts a loop's jumps at its keys into `metrics` (path_metrics of the period): `jumps`
    (velocity, acceleration) from quatcurve.key_jumps through the seam (Seam.key_frames: the keys with
    a neighbour across the seam on each side), so the first and last key — the seam — have theirs
    like every other key, and the largest jumps and their keys count the seam."""
    for kind, values in zip(("velocity", "acceleration"), jumps):
        values = np.asarray(values, np.float64)[1:-1]   # the keys themselves (the neighbours have one side)
        metrics[kind + "_jumps"] = values
        finite = np.isfinite(values)
        if finite.any():
            at = int(np.flatnonzero(finite)[np.argmax(values[finite])])
            metrics["max_%s_jump" % kind], metrics["max_%s_jump_time" % kind] = float(values[at]), float(key_frames[at])


def compare_target(target, settings):
    """TargetComparison of one target (see the module doc). Raises CompareError."""
    return measure(read_target(target, settings), settings)


def _compress_frames(frames, limit=50):
    """The first `limit` frames (a long stretch near gimbal lock lists its start)."""
    return [float(f) for f in np.asarray(frames)[:limit]]


def recommend(comparison):
    """The recommendation for one target (docs/compare.md, "The recommendation"):

    1. eligible: the engine methods that pass through the keys (within KEY_TOLERANCE_DEG of SLERP
       at every key frame), obey the path rule in every key segment, do not drift where the keys
       hold (path below KEY_TOLERANCE_DEG in a segment whose keys coincide), and keep a steady speed:
       in every moving segment the speed ratio is at most STEADY_EXCESS × the ratio the keys
       themselves ask for (keyed_speed_ratios; a stop is allowed only where the keys reverse or hold);
    2. "no difference" when every eligible method stays within half a sample step of every other
       (the sampling cannot tell them apart): the first eligible method in ENGINE_METHODS is named;
    3. otherwise, among the eligible: the ones smooth at the keys (velocity jump at most
       SMOOTH_JUMP_FRACTION of the mean keyed speed) first, then the least extra path (sampled path
       minus the keyed arcs), then the steadiest speed; with no eligible method, the steadiest of
       all (the smallest speed excess), said so.
    constant_speed_method: the smallest speed excess of all engine methods; euler_order: the order
    whose closest approach to gimbal lock over the motion is farthest."""
    qc = native.require()
    engine = {n: s for n, s in comparison.sources.items() if s.kind == "engine"}
    frames, key_frames = comparison.frames, comparison.key_frames
    at_keys = np.searchsorted(frames, key_frames)
    arcs = engine[REFERENCE_METHOD].segment_paths[:, 0]
    hold = arcs <= math.radians(KEY_TOLERANCE_DEG)
    allowed = comparison.keyed_speed_ratios
    duration = float(key_frames[-1] - key_frames[0])
    mean_keyed_speed = float(arcs.sum()) / duration if duration > 0 else 0.0

    verdicts = {}
    for name, s in engine.items():
        m = s.metrics
        reasons = []
        key_error = float(np.max(m["deviation"][at_keys]))
        if key_error > math.radians(KEY_TOLERANCE_DEG):
            reasons.append("misses a key by %.3f°" % math.degrees(key_error))
        broken = [b for b in comparison.path_rule if b.method == name]
        if broken:
            reasons.append("breaks the path rule at frames %g-%g" % (broken[0].frame_start, broken[0].frame_end))
        paths = s.segment_paths[:, 1]
        drift = float(np.max(paths[hold], initial=0.0))
        if drift > math.radians(KEY_TOLERANCE_DEG):
            reasons.append("drifts %.2f° where the keys hold" % math.degrees(drift))
        ratios = np.asarray(m["segment_speed_ratios"], dtype=np.float64)
        exempt = hold | ~np.isfinite(allowed)  # holds, and stops the keys ask for
        with np.errstate(invalid="ignore", divide="ignore"):
            excess = np.where(exempt, 1.0, ratios / np.where(exempt, 1.0, allowed))
        excess = np.where(np.isnan(excess), np.inf, excess)
        worst = int(np.argmax(excess)) if len(excess) else 0
        speed_excess = float(excess[worst]) if len(excess) else 1.0
        if speed_excess > STEADY_EXCESS:
            reasons.append("%s at frames %g-%g" % (
                "stops" if not math.isfinite(speed_excess) or ratios[worst] >= STOP_RATIO
                else "speed varies %.1f× more than the keys ask" % speed_excess,
                key_frames[worst], key_frames[worst + 1]))
        smooth = bool(m["max_velocity_jump"] <= SMOOTH_JUMP_FRACTION * mean_keyed_speed + 1e-9)
        verdicts[name] = {"eligible": not reasons, "reasons": reasons, "smooth": smooth,
                          "speed_excess": _num(speed_excess),
                          "extra_path_deg": math.degrees(max(float(paths.sum() - s.segment_paths[:, 0].sum()), 0.0)),
                          "key_error_deg": math.degrees(key_error)}

    listed = ENGINE_METHODS.index
    eligible = sorted((n for n in engine if verdicts[n]["eligible"]), key=listed)

    def excess_of(n):
        e = verdicts[n]["speed_excess"]
        return math.inf if e is None else e

    # Agreement: the largest angle between any two eligible methods' paths, against the sampling's
    # resolution (half the largest angle the reference moves between two samples).
    reference = engine[REFERENCE_METHOD].quats
    sampling_error = 0.5 * float(np.max(qc.angular_deviation(reference[1:], reference[:-1]), initial=0.0))
    spread = 0.0
    for i, a in enumerate(eligible):
        for b in eligible[i + 1:]:
            spread = max(spread, float(np.max(qc.angular_deviation(engine[a].quats, engine[b].quats))))
    no_difference = len(eligible) >= 1 and spread <= sampling_error + 1e-12

    label = methods.label  # the text names methods as the menus do; the fields keep identifiers
    if no_difference:
        method = eligible[0]
        text = "no difference: %s agree within %.2f°, under the sampling's %.2f° (half a sample step); %s" % (
            ", ".join(map(label, eligible)) if len(eligible) < len(engine) else "all methods", math.degrees(spread),
            math.degrees(sampling_error), label(method))
    elif eligible:
        method = min(eligible, key=lambda n: (not verdicts[n]["smooth"], round(verdicts[n]["extra_path_deg"], 3),
                                              round(excess_of(n), 3), listed(n)))
        v = verdicts[method]
        text = "%s: passes the keys, obeys the path rule, steady (speed ratio at most %.2f× the keys' own), " \
               "%s, %.2f° of extra path" % (
                   label(method), excess_of(method),
                   "smooth at keys" if v["smooth"] else "not smooth at keys (velocity jumps %.2f°/frame; no smooth "
                   "method is eligible)" % math.degrees(engine[method].metrics["max_velocity_jump"]),
                   v["extra_path_deg"])
    else:
        method = min(engine, key=lambda n: (round(excess_of(n), 3), listed(n)))
        text = "%s, with reservations: no method is eligible (%s: %s)" % (
            label(method), label(method), "; ".join(verdicts[method]["reasons"]))
    others = [n for n in engine if n not in eligible]
    if others and not no_difference:
        text += "; not: " + ", ".join("%s (%s)" % (label(n), verdicts[n]["reasons"][0]) for n in others)
    steadiest = min(engine, key=lambda n: (round(excess_of(n), 3), listed(n)))
    order = max(comparison.euler_orders, key=lambda o: comparison.euler_orders[o][0])
    text += "; Euler order %s stays %.1f° from gimbal lock" % (order, math.degrees(comparison.euler_orders[order][0]))
    return {"method": method, "no_difference": bool(no_difference), "eligible": eligible,
            "agreement_deg": math.degrees(spread), "sampling_error_deg": math.degrees(sampling_error),
            "constant_speed_method": steadiest, "euler_order": order, "methods": verdicts, "text": text}


def keyed_speed_ratios(key_frames, arcs, key_quats):
    """Per key segment, the speed ratio the keys themselves ask for: the largest over the smallest
    keyed speed (arc / frames) of the segment and its neighbours — 1 for evenly spaced keys, more
    where the keys speed up or slow down; inf (a stop is expected) where a neighbour holds or the
    motion reverses at one of the segment's keys (the outgoing direction turns more than REVERSAL_DEG
    from the incoming one)."""
    qc = native.require()
    k = len(key_frames)
    speeds = np.asarray(arcs, np.float64) / np.diff(np.asarray(key_frames, np.float64))
    moving = np.asarray(arcs) > math.radians(KEY_TOLERANCE_DEG)
    reverses = np.zeros(k, bool)
    if k > 2:
        q = np.asarray(key_quats, np.float64)
        inverse = qc.quat_inverse(q[1:-1])
        back, ahead = qc.quat_multiply(inverse, q[:-2]), qc.quat_multiply(inverse, q[2:])
        back = qc.quat_log(back * np.sign(back[:, :1] + 1e-300))[:, 1:]   # towards the previous key
        ahead = qc.quat_log(ahead * np.sign(ahead[:, :1] + 1e-300))[:, 1:]         # towards the next key
        # The turn at the key: the angle between the incoming direction (−back) and the outgoing one.
        cos_turn = -np.einsum("ij,ij->i", back, ahead) / np.maximum(
            np.linalg.norm(back, axis=1) * np.linalg.norm(ahead, axis=1), 1e-300)
        reverses[1:-1] = cos_turn < math.cos(math.radians(REVERSAL_DEG))
    out = np.empty(k - 1)
    for i in range(k - 1):
        near = speeds[max(i - 1, 0):i + 2]
        stop = reverses[i] or reverses[i + 1] or not moving[max(i - 1, 0):i + 2].all()
        out[i] = math.inf if stop else float(near.max() / near.min())
    return out


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
    # Blender is read on this thread, target after target, while worker threads measure the targets
    # already read (the native curves and metrics run without the GIL).
    readings = (read_target(target, settings) for target in found)
    report.targets.extend(parallel_imap(lambda reading: measure(reading, settings), readings))
    report.seconds = time.perf_counter() - begin
    return report


# ---- output: JSON, PNG, image datablocks ----------------------------------------------------------------------

def plot_path(report_path, target_name):
    """PNG path of a target's plot beside the report: <report without .json>_<target>.png, the target
    name reduced to letters, digits, '-', '_' and '.' ('Armature/Bone' → 'Armature_Bone')."""
    stem = report_path[:-5] if report_path.lower().endswith(".json") else report_path
    return "%s_%s.png" % (stem, re.sub(r"[^A-Za-z0-9_.-]+", "_", target_name))


def save_plots(report, report_path):
    """Saves each target's plot as a PNG beside `report_path` (see plot_path) and makes it the target's
    image datablock: the PNG is encoded here (plot.png_bytes; worker threads draw and encode the
    targets while this thread writes the ones done), then Blender loads the file as the image
    (image_name(target), with a fake user, replacing an older one of that name) and packs it from
    that file, so it is saved with the .blend too. The image's pixels are the drawn ones exactly
    (bytes / 255), as when Blender encodes them. Returns the PNG paths."""
    folder = os.path.dirname(os.path.abspath(report_path))
    os.makedirs(folder, exist_ok=True)
    pngs = []
    encoded = parallel_imap(lambda t: plot.png_bytes(t.render_plot()), report.targets)
    try:
        for t, data in zip(report.targets, encoded):
            path = plot_path(report_path, t.name)
            try:
                with open(path, "wb") as f:
                    f.write(data)
            except OSError as error:
                raise OSError("%s: writing the plot %s failed: %s" % (t.name, path, error.strerror or error)) from None
            _remove_plot_image(t)
            image = bpy.data.images.load(path, check_existing=False)
            image.name = image_name(t.name)
            image.use_fake_user = True
            image.pack()
            t.image_name, t.plot_file = image.name, os.path.basename(path)
            pngs.append(path)
    finally:
        encoded.close()  # an error: stop the workers now
    return pngs


def write_report(report, report_path):
    """Writes the JSON report at `report_path` and, unless save_plots did already, each target's plot as
    a PNG beside it; returns (report_path, [png paths]). The JSON names each target's PNG (file name
    only, relative to the report's folder); its schema is report.schema.json beside this file."""
    if all(t.plot_file and t.image_name for t in report.targets):
        folder = os.path.dirname(os.path.abspath(report_path))
        pngs = [os.path.join(folder, t.plot_file) for t in report.targets]
    else:
        pngs = save_plots(report, report_path)
    data = report.to_json()
    tmp = report_path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        # One line per target: json's C encoder (an indented dump runs the pure-Python one, ~10x slower).
        head = {k: v for k, v in data.items() if k != "targets"}
        f.write(json.dumps(head, allow_nan=False)[:-1] + (", " if head else "") + '"targets": [\n')
        f.write(",\n".join(json.dumps(t, allow_nan=False) for t in data.get("targets", [])))
        f.write("\n]}\n")
    os.replace(tmp, report_path)
    return report_path, pngs


def image_name(target_name):
    return "QuatCurve compare: " + target_name


_BYTE_TO_FLOAT = np.arange(256, dtype=np.float32) / np.float32(255.0)


def plot_image(comparison):
    """The image datablock holding a target's plot (Image Editor): the one already made for this
    comparison, else a new one named image_name(target), replacing an older one of that name, with a
    fake user. Blender's pixels are floats 0..1, rows bottom to top. Not packed yet: make_images or
    save_plots packs it (an unpacked generated image would lose its pixels in a saved .blend)."""
    image = bpy.data.images.get(comparison.image_name) if comparison.image_name else None
    if image is not None:
        return image
    _remove_plot_image(comparison)
    pixels = comparison.render_plot()
    image = bpy.data.images.new(image_name(comparison.name), pixels.shape[1], pixels.shape[0], alpha=True)
    image.pixels.foreach_set(_BYTE_TO_FLOAT[pixels[::-1]].ravel())  # one gather, float32 straight away
    image.use_fake_user = True
    comparison.image_name = image.name
    return image


def _remove_plot_image(comparison):
    """Removes the image datablock of an older plot of the comparison's target (image_name), if any."""
    old = bpy.data.images.get(image_name(comparison.name))
    if old is not None:
        bpy.data.images.remove(old)
    comparison.image_name = None


def make_images(report):
    """One packed image datablock per target holding its plot (plot_image), replacing older ones of the
    same name; for a comparison without a report path (save_plots packs the others from their PNG).
    Returns the images."""
    images = []
    for t in report.targets:
        t.image_name, t.plot_file = None, None
        image = plot_image(t)
        image.pack()
        images.append(image)
    return images


def last_plot_image(target_name):
    """The image datablock of the last comparison plot of a target ('Cube', 'Armature/Bone'), or
    None. For the UI."""
    return bpy.data.images.get(image_name(target_name))
