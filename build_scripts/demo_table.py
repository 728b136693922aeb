"""Prints the comparison table of a compare report (report.json, written by the CLI's --compare).

    python demo_table.py out/report.json

Objects get their full table: one row per source (Blender's own curves, Blender's Euler and
quaternion modes with the same keys, the engine's methods) with the max deviation from SLERP, the
in-segment speed ratio (1.000 = constant speed; "stops" = comes to a halt inside a segment) and
the path length, then the recommendation. Pose bones (many, from motion capture) get one row each.
Plain JSON reading: runs in any Python 3.
"""

import json
import os
import sys

STOP_RATIO = 100.0  # as compare.py: beyond this the path halts inside a segment


def ratio_text(ratio):
    return "stops" if ratio is None or ratio >= STOP_RATIO else "%.3f" % ratio


def frames_text(frames):
    frames = ["%g" % f for f in frames]
    return ", ".join(frames) if len(frames) <= 6 else "%s … %s (%d keys)" % (frames[0], frames[-1], len(frames))


def object_table(target):
    lines = ["%s (%s, keys %s)" % (target["name"], target["rotation_mode"], frames_text(target["key_frames"])),
             "  %-20s %10s %12s %12s" % ("source", "max dev", "speed ratio", "path length")]
    for name, s in target["sources"].items():
        lines.append("  %-20s %9.2f° %12s %11.1f°" % (name, s["max_deviation_deg"], ratio_text(s["speed_ratio"]),
                                                      s["path_length_deg"]))
    for b in target["path_rule"]:
        lines.append("  path rule: %s frames %g-%g: path %.1f° vs keyed arc %.1f° (%s)" % (
            b["method"], b["frame_start"], b["frame_end"], b["path_deg"], b["arc_deg"],
            "a hold" if b["ratio"] is None else "%.2f×" % b["ratio"]))
    lines.append("  -> " + target["recommendation"]["text"])
    return lines


def bone_table(targets):
    """One row per bone: Blender's own curves and the recommended method against SLERP ("no
    difference": the methods agree within the sampling error; its figures are then SLERP's)."""
    lines = ["  %-22s %12s %13s  %-13s %9s %10s  %s" % (
        "bone", "Blender dev", "Blender ratio", "recommended", "its dev", "its ratio", "Euler")]
    for t in targets:
        blender = t["sources"]["BLENDER"]
        rec = t["recommendation"]
        best = t["sources"][rec["method"]]
        lines.append("  %-22s %11.3f° %13s  %-13s %8.3f° %10s  %s" % (
            t["name"], blender["max_deviation_deg"], ratio_text(blender["speed_ratio"]),
            "no difference" if rec["no_difference"] else rec["method"],
            best["max_deviation_deg"], ratio_text(best["speed_ratio"]), rec["euler_order"]))
    return lines


def main(path):
    with open(path, encoding="utf-8") as f:
        report = json.load(f)
    settings = report["settings"]
    print("Comparison (%s; Blender %s, sampled every 1/%d frame, Blender's modes with %s keys; "
          "deviations from %s)" % (os.path.relpath(path), report["blender_version"], settings["subframes"],
                                   settings["key_interpolation"].lower(), "SLERP"))
    objects = [t for t in report["targets"] if "/" not in t["name"]]
    bones = [t for t in report["targets"] if "/" in t["name"]]
    for t in objects:
        print()
        print("\n".join(object_table(t)))
    if bones:
        print()
        print("%d pose bones (full tables and plots in the report; Euler: the order farthest from gimbal lock)"
              % len(bones))
        print("\n".join(bone_table(bones)))


if __name__ == "__main__":
    main(sys.argv[1])
