"""The path rule (docs/curves.md): between two keys a curve's sampled path may be at most
PATH_RULE_FACTOR × the keyed arc + PATH_RULE_SLACK (1.5 × arc + 10°). The clamped methods obey it by
construction; SPLINE_C2 (never clamped) and textbook tangents may not, so bake and compare report
every key segment that breaks it: the target, the frames, the path and the ratio.

Plain numbers from the native curve (`Curve.segment_paths`: keyed arc and sampled path length per
key segment, radians); no Blender data.
"""

import math
from dataclasses import dataclass

from . import methods, native


@dataclass
class PathRuleBreak:
    target: str
    method: str
    frame_start: float
    frame_end: float
    arc: float       # keyed arc, radians
    path: float      # sampled path length, radians

    @property
    def ratio(self):
        """path / keyed arc (inf for a hold, where the keys do not move)."""
        return self.path / self.arc if self.arc > 0 else math.inf

    @property
    def allowed(self):
        qc = native.require()
        return qc.PATH_RULE_FACTOR * self.arc + qc.PATH_RULE_SLACK

    def text(self):
        ratio = "a hold" if not math.isfinite(self.ratio) else "%.2f × its keyed arc %.1f°" % (
            self.ratio, math.degrees(self.arc))
        return "%s: %s, frames %g-%g: path %.1f° is %s (the path rule allows %.1f°)" % (
            self.target, methods.label(self.method), self.frame_start, self.frame_end, math.degrees(self.path), ratio,
            math.degrees(self.allowed))

    def to_json(self):
        return {"method": self.method, "frame_start": float(self.frame_start), "frame_end": float(self.frame_end),
                "arc_deg": math.degrees(self.arc), "path_deg": math.degrees(self.path),
                "ratio": self.ratio if math.isfinite(self.ratio) else None}


def breaks(curve, key_frames, target, method, segment_paths=None, rows=None):
    """[PathRuleBreak] of `curve` (a quatcurve.Curve through keys at key_frames), one per key segment
    whose sampled path is longer than the rule allows; [] when it obeys it everywhere.

    segment_paths: the curve's Curve.segment_paths() when the caller already has them (compare);
    rows: its Curve.path_rule_breaks() when the caller has them (a quatcurve.BakeQueue gives them;
    curve may then be None); otherwise Curve.path_rule_breaks() answers, which samples nothing where
    the construction already settled the rule (SLERP, NLERP, the clamped SQUAD, TCB and CATMULL_ROM)."""
    if rows is not None:
        rows = [(int(i), arc, path) for i, arc, path in rows]
    elif segment_paths is None:
        rows = [(int(i), arc, path) for i, arc, path in curve.path_rule_breaks()]
    else:
        qc = native.require()
        rows = [(i, arc, path) for i, (arc, path) in enumerate(segment_paths)
                if path > qc.PATH_RULE_FACTOR * arc + qc.PATH_RULE_SLACK]
    return [PathRuleBreak(target, method, float(key_frames[i]), float(key_frames[i + 1]), float(arc), float(path))
            for i, arc, path in rows]
