"""Compare (addon/quatcurve_blender/compare.py and the quatcurve.compare operator) in background mode.

Keys are made with keyframe_insert (auto-clamped Bezier) and, where a test needs LINEAR keys,
rewritten through the F-curve adapter; Blender's modes are evaluated by Blender in scratch actions.
"""

import json
import math
import os

import bpy
import numpy as np
import pytest
from mathutils import Euler, Quaternion

from compare_helpers import image_pixels, load_png, report_schema, schema_errors
from conftest import ROOT, SHARED
from quatcurve_blender import bake, compare, fcurves, fit, plot, targets

COMPARE_DOC = os.path.join(ROOT, "docs", "compare.md")


@pytest.fixture
def linear_keys(scene):
    """The scene; keyed_object makes LINEAR keys."""
    return scene


def keyed_object(scene, name, mode, keys, interpolation="LINEAR"):
    """An empty in `mode` keyed at {frame: value} (Euler angles in degrees, or a quaternion), its keys
    of `interpolation` (keyframe_insert makes BEZIER keys; others are rewritten through fcurves.py)."""
    obj = bpy.data.objects.new(name, None)
    scene.collection.objects.link(obj)
    obj.rotation_mode = mode
    for frame, value in keys.items():
        if mode == "QUATERNION":
            obj.rotation_quaternion = value
            obj.keyframe_insert("rotation_quaternion", frame=frame)
        else:
            obj.rotation_euler = [math.radians(v) for v in value]
            obj.keyframe_insert("rotation_euler", frame=frame)
    if interpolation != "BEZIER":
        for fcurve in fcurves.Channels.of(obj).fcurves:
            fcurves.write_keys(fcurve, *fcurves.read_keys(fcurve), interpolation=interpolation)
    return obj


def fixed_angle(scene):
    return keyed_object(scene, "Fixed", "XYZ", {1: (0, 90, 0), 21: (90, 45, 90)})


def digests():
    """Every action's F-curves with their keys and handles, through the adapter's bulk reads."""
    return {a.name: sorted((f.data_path, f.array_index, *(v.tobytes() for v in fcurves.read_keys(f)),
                            *(h.tobytes() for h in fcurves.read_handles(f)))
                           for f in fcurves.all_fcurves(a))
            for a in bpy.data.actions}


def frame_index(comparison, frame):
    return int(np.flatnonzero(np.isclose(comparison.frames, frame))[0])


# ---- the numbers ------------------------------------------------------------------------------

def test_fixed_angle_euler_mode_lies_17_13_degrees_from_slerp(linear_keys):
    obj = fixed_angle(linear_keys)
    report = compare.compare([targets.Target(obj)])
    t = report.targets[0]
    mid = frame_index(t, 11)
    # The target's own LINEAR Euler keys, and Blender's Euler mode with auto-clamped Bezier keys (the
    # same at the middle frame of a two-key segment, by symmetry).
    for source in ("BLENDER", "BLENDER_EULER_XYZ"):
        assert math.degrees(t.sources[source].metrics["deviation"][mid]) == pytest.approx(17.13, abs=0.05)
    assert t.sources["SLERP"].metrics["max_deviation"] == 0.0
    # SLERP's midpoint is (90, 67.5, 90).
    slerp_mid = Quaternion(t.sources["SLERP"].quats[mid]).to_euler("XYZ")
    assert np.degrees(slerp_mid) == pytest.approx([90, 67.5, 90], abs=1e-3)


def test_blender_modes_use_blenders_default_bezier_keys(scene):
    # Two auto-clamped Bezier keys 0 → 1 over frames 1..21: flat handles a third of the way in, so
    # Blender evaluates smoothstep 3u² − 2u³ (u = 0.25 → 0.15625); LINEAR gives u.
    frames = [1.0, 6.0, 11.0, 16.0, 21.0]
    bezier = fcurves.evaluate_scratch_keys("rotation_euler", [1.0, 21.0], [[0.0], [1.0]], frames)
    np.testing.assert_allclose(bezier[:, 0], [0, 0.15625, 0.5, 0.84375, 1], atol=1e-6)
    linear = fcurves.evaluate_scratch_keys("rotation_euler", [1.0, 21.0], [[0.0], [1.0]], frames, "LINEAR")
    np.testing.assert_allclose(linear[:, 0], [0, 0.25, 0.5, 0.75, 1], atol=1e-6)
    assert len(bpy.data.actions) == 0  # the scratch action is gone


def test_slerp_speed_ratio_is_one_inside_every_segment(linear_keys):
    obj = keyed_object(linear_keys, "Wander", "XYZ",
                       {1: (0, 0, 0), 8: (40, 10, -30), 30: (80, 60, 20), 35: (50, 10, 80)})
    t = compare.compare([targets.Target(obj)], compare.CompareSettings(subframes=3)).targets[0]
    ratios = t.sources["SLERP"].metrics["segment_speed_ratios"]
    assert len(ratios) == 3
    np.testing.assert_allclose(ratios, 1.0, atol=1e-6)
    assert t.sources["SLERP"].metrics["speed_ratio"] == pytest.approx(1.0, abs=1e-6)
    # The smooth methods are continuous at keys, SLERP is not.
    assert t.sources["SLERP"].metrics["max_velocity_jump"] > 0.01
    assert t.sources["SPLINE_C2"].metrics["max_velocity_jump"] < 0.1 * t.sources["SLERP"].metrics["max_velocity_jump"]


@pytest.mark.parametrize("degrees", [150.0, 90.0])
def test_linear_quaternion_segment_has_the_speed_ratio_of_nlerp(linear_keys, degrees):
    theta = math.radians(degrees)
    end = Quaternion((0.6, 0.0, 0.8), theta)
    obj = keyed_object(linear_keys, "Quat", "QUATERNION", {1: (1, 0, 0, 0), 25: tuple(end)})
    settings = compare.CompareSettings(subframes=8, key_interpolation="LINEAR")
    t = compare.compare([targets.Target(obj)], settings).targets[0]
    expected = 2 / (1 + math.cos(theta / 2))  # ≈ 1.589 at 150°
    assert t.sources["BLENDER"].metrics["speed_ratio"] == pytest.approx(expected, rel=1e-3)
    assert t.sources["BLENDER_QUATERNION"].metrics["speed_ratio"] == pytest.approx(expected, rel=1e-3)
    assert t.sources["NLERP"].metrics["speed_ratio"] == pytest.approx(expected, rel=1e-3)
    assert t.sources["SLERP"].metrics["speed_ratio"] == pytest.approx(1.0, abs=1e-6)


# ---- report, plot, untouched animation ----------------------------------------------------------------------

def test_report_png_and_json(linear_keys, tmp_path):
    fixed = fixed_angle(linear_keys)
    quat = keyed_object(linear_keys, "Quat", "QUATERNION",
                        {1: (1, 0, 0, 0), 11: tuple(Quaternion((0, 0, 1), 2.0)), 31: tuple(Quaternion((1, 1, 0), 2.5))})
    before = digests()
    report = compare.compare([targets.Target(fixed), targets.Target(quat)], compare.CompareSettings(all_euler_orders=True))
    path, pngs = compare.write_report(report, str(tmp_path / "report.json"))
    assert digests() == before  # scratch actions removed, the user's keys untouched

    assert [os.path.basename(p) for p in pngs] == ["report_Fixed.png", "report_Quat.png"]
    for t, png in zip(report.targets, pngs):
        # Saved by Blender and read back by Blender: the drawn pixels, exactly (bytes / 255).
        expected = t.render_plot().astype(np.float32) / 255
        np.testing.assert_allclose(load_png(png), expected, atol=1e-6)
        image = bpy.data.images[t.image_name]
        assert image.use_fake_user and image.packed_file is not None
        np.testing.assert_allclose(image_pixels(image), expected, atol=1e-6)

    with open(path) as f:
        data = json.load(f)
    assert schema_errors(data) == []
    assert data["blender_version"] == bpy.app.version_string
    names = [t["name"] for t in data["targets"]]
    assert names == ["Fixed", "Quat"]
    fixed_json = data["targets"][0]
    assert set(fixed_json["sources"]) == {"BLENDER", "BLENDER_QUATERNION", *compare.ENGINE_METHODS,
                                         *(compare.euler_source(o) for o in fcurves.EULER_ORDERS)}
    assert fixed_json["frames"] == {"start": 1.0, "end": 21.0, "step": 1.0, "count": 21}
    assert fixed_json["plot"] == "report_Fixed.png"
    # (0, 90°, 0) in XYZ is gimbal lock: the closest approach is 0 at frame 1, and XYZ is not recommended.
    gimbal = fixed_json["sources"]["BLENDER_EULER_XYZ"]["gimbal"]
    assert gimbal["order"] == "XYZ" and gimbal["closest_deg"] == pytest.approx(0.0, abs=1e-3)
    assert gimbal["frames"][0] == 1.0
    assert fixed_json["recommendation"]["euler_order"] != "XYZ"
    # Auto-clamped Bezier keys ease to a stop at the first and last key.
    ratio = fixed_json["sources"]["BLENDER_EULER_XYZ"]["speed_ratio"]
    assert ratio is None or ratio > compare.STOP_RATIO


def test_compare_doc_documents_every_report_field():
    with open(COMPARE_DOC, encoding="utf-8") as f:
        text = f.read()
    missing = [name for name in schema_property_names(report_schema()) if "`%s`" % name not in text]
    assert missing == []


def test_operator_on_selection_writes_report_image_and_table(linear_keys, tmp_path):
    obj = fixed_angle(linear_keys)
    other = keyed_object(linear_keys, "Unselected", "XYZ", {1: (0, 0, 0), 5: (0, 0, 90)})
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    before, actions = digests(), len(bpy.data.actions)
    report_path = str(tmp_path / "out" / "compare.json")
    assert bpy.ops.quatcurve.compare(report_path=report_path) == {"FINISHED"}
    assert digests() == before and len(bpy.data.actions) == actions
    assert os.path.isfile(report_path) and os.path.isfile(str(tmp_path / "out" / "compare_Fixed.png"))
    image = compare.last_plot_image("Fixed")
    assert image is not None and image.name == compare.image_name("Fixed")
    assert tuple(image.size) == (plot.WIDTH, plot.HEIGHT)
    np.testing.assert_allclose(load_png(str(tmp_path / "out" / "compare_Fixed.png")), image_pixels(image), atol=1e-6)
    table = json.loads(linear_keys.quatcurve_compare.last_table)
    assert [t["name"] for t in table] == ["Fixed"]  # only the selection
    rows = {r[0]: r for r in table[0]["rows"]}
    assert rows["SLERP"][1:] == ["0.00°", "1.000", rows["SLERP"][3]]
    assert other.name not in linear_keys.quatcurve_compare.last_table


def test_operator_refuses_without_selection_or_animation(linear_keys):
    # In background mode an operator that reports an error (and returns CANCELLED) raises RuntimeError.
    with pytest.raises(RuntimeError, match="Nothing to compare: no objects selected"):
        bpy.ops.quatcurve.compare()
    still = bpy.data.objects.new("Still", None)
    linear_keys.collection.objects.link(still)
    still.select_set(True)
    with pytest.raises(RuntimeError, match="Still: no rotation animation"):
        bpy.ops.quatcurve.compare()
    with pytest.raises(compare.CompareError, match="Still: no rotation animation"):
        compare.compare([targets.Target(still)])


def test_pose_bone_and_spin(linear_keys):
    arm = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm)
    linear_keys.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    for name, head in (("Root", (0, 0, 0)), ("Tip", (0, 0, 1))):
        bone = arm.edit_bones.new(name)
        bone.head, bone.tail = head, (head[0], head[1], head[2] + 1)
    bpy.ops.object.mode_set(mode="OBJECT")
    pb = rig.pose.bones["Tip"]
    pb.rotation_mode = "XYZ"
    for frame, z in ((1, 0), (11, 100), (21, 200), (31, 300), (41, 400)):  # a 400° spin
        pb.rotation_euler = (0, 0, math.radians(z))
        pb.keyframe_insert("rotation_euler", frame=frame)
    before = digests()
    t = compare.compare([targets.Target(rig, "Tip")]).targets[0]
    assert digests() == before
    assert t.name == "Rig/Tip"
    # Every method keeps the full 400° turn of the Euler keys; key-to-key geodesics sum to the same.
    for name in ("BLENDER", "BLENDER_EULER_XYZ", "SLERP", "SPLINE_C2"):
        assert math.degrees(t.sources[name].metrics["path_length"]) == pytest.approx(400, abs=0.5), name
    assert math.degrees(t.sources["SLERP"].metrics["key_path_length"]) == pytest.approx(400, abs=1e-3)
    assert compare.plot_path("/x/r.json", t.name) == "/x/r_Rig_Tip.png"


def test_bad_settings():
    with pytest.raises(compare.CompareError, match="subframes"):
        compare.check_settings(compare.CompareSettings(subframes=0))
    with pytest.raises(compare.CompareError, match="key interpolation"):
        compare.check_settings(compare.CompareSettings(key_interpolation="CONSTANT"))
    with pytest.raises(compare.CompareError, match="method 'EULER'"):
        compare.check_settings(compare.CompareSettings(methods=("EULER",)))


def schema_property_names(schema):
    """Every property name a JSON schema (with $defs) defines."""
    names = set()
    if isinstance(schema, dict):
        names |= set(schema.get("properties", {}))
        for value in schema.values():
            names |= schema_property_names(value)
    elif isinstance(schema, list):
        for value in schema:
            names |= schema_property_names(value)
    return names


class FakeLayout:
    """Records labels and props; enough of UILayout for the panel's compare drawing."""

    def __init__(self, lines=None):
        self.lines = [] if lines is None else lines

    def box(self):
        return FakeLayout(self.lines)

    column = row = split = lambda self, **kwargs: FakeLayout(self.lines)

    def label(self, text="", icon="NONE"):
        self.lines.append(text)

    def prop(self, data, name, text=None):
        assert hasattr(data, name), name
        self.lines.append("prop " + name)

    def operator(self, idname, text="", icon="NONE"):
        self.lines.append("operator " + idname)
        return type("OperatorProperties", (), {})()


def test_panel_draws_the_last_table(linear_keys):
    from quatcurve_blender import ui
    obj = fixed_angle(linear_keys)
    obj.select_set(True)
    assert bpy.ops.quatcurve.compare() == {"FINISHED"}
    layout = FakeLayout()
    ui.draw_compare_settings(layout, linear_keys.quatcurve_compare)
    ui.draw_compare_table(layout, linear_keys.quatcurve_compare)
    assert "prop subframes" in layout.lines and any(line.startswith("Fixed ") for line in layout.lines)
    assert "Slerp" in layout.lines and "0.00°" in layout.lines and "1.000" in layout.lines
    assert any("gimbal" in line for line in layout.lines)  # the recommendation, wrapped


# ---- the plot's pixels, read back through Blender -----------------------------------------------------------

def test_the_slerp_speed_line_lies_at_the_row_of_its_speed(linear_keys):
    # SLERP is drawn last (methods=SLERP only) and runs at the keyed arc / frames in each segment:
    # 90°/20 frames = 4.5°/frame, then 30°/10 frames = 3°/frame.
    obj = keyed_object(linear_keys, "Turn", "XYZ", {1: (0, 0, 0), 21: (0, 0, 90), 31: (0, 0, 120)})
    settings = compare.CompareSettings(subframes=4, methods=("SLERP",))
    report = compare.compare([targets.Target(obj)], settings)
    t = report.targets[0]
    assert list(t.sources)[-1] == "SLERP"
    pixels = image_pixels(compare.make_images(report)[0]) * 255
    speed_panel, _ = plot.make_panels(None, t.plot_series(), t.key_frames)
    colour = plot.PALETTE[len(t.sources) - 1]
    for frame, speed in ((6.0, 4.5), (15.0, 4.5), (26.0, 3.0)):
        x, y = speed_panel.to_pixels(frame, speed)
        np.testing.assert_allclose(pixels[int(y), int(x), :3], colour, atol=0.5, err_msg=str(frame))
        assert not np.allclose(pixels[int(y) + 4, int(x), :3], colour, atol=0.5)
    # The axes in ink, the margin in the background colour, the SLERP swatch in its colour.
    left, top, right, bottom = speed_panel.box
    np.testing.assert_allclose(pixels[bottom, (left + right) // 2, :3], plot.INK, atol=0.5)
    np.testing.assert_allclose(pixels[3, 3, :3], plot.BACKGROUND, atol=0.5)
    y = 90 + 34 + (len(t.sources) - 1) * 22 + 6
    np.testing.assert_allclose(pixels[y, plot.LEGEND_LEFT + 20, :3], colour, atol=0.5)


# ---- the recommendation ---------------------------------------------------------------------------------------

def recommendation(scene, name, mode, keys, subframes=4):
    obj = keyed_object(scene, name, mode, keys)
    t = compare.compare([targets.Target(obj)], compare.CompareSettings(subframes=subframes)).targets[0]
    return t, t.recommendation


def test_evenly_spaced_keys_on_one_axis_recommend_a_smooth_method(linear_keys):
    t, rec = recommendation(linear_keys, "Even", "XYZ", {f: (f - 1, 0, 0) for f in (1, 11, 21, 31, 41)})
    chosen = t.sources[rec["method"]].metrics
    assert rec["methods"][rec["method"]]["smooth"]
    assert math.degrees(chosen["max_velocity_jump"]) < 0.01
    assert chosen["speed_ratio"] == pytest.approx(1.0, abs=1e-3)
    # Every method takes the same path at the same speed here: nothing to choose.
    assert rec["no_difference"] and rec["text"].startswith("no difference")


def test_holds_recommend_no_method_that_drifts(linear_keys):
    t, rec = recommendation(linear_keys, "Hold", "XYZ",
                            {1: (0, 0, 0), 11: (0, 0, 0), 21: (0, 0, 120), 31: (0, 0, 120), 41: (0, 0, 0), 51: (0, 0, 0)})
    assert not rec["no_difference"]
    assert rec["method"] != "SPLINE_C2"
    verdict = rec["methods"]["SPLINE_C2"]
    assert not verdict["eligible"] and any("drifts" in r or "path rule" in r for r in verdict["reasons"])
    chosen = rec["methods"][rec["method"]]
    assert chosen["eligible"] and chosen["smooth"]  # the clamped methods ease into the holds
    holds = [0, 2, 4]
    assert np.degrees(t.sources[rec["method"]].segment_paths[holds, 1]).max() < compare.KEY_TOLERANCE_DEG


def test_hemisphere_recommends_a_steady_method(linear_keys):
    s, c = math.sin(math.radians(60)), math.cos(math.radians(60))
    t, rec = recommendation(linear_keys, "Hemisphere", "QUATERNION",
                            {1: (1, 0, 0, 0), 21: (c, s, 0, 0), 41: (-c, 0, -s, 0), 61: (0.5, 0.5, 0.5, 0.5)})
    chosen = rec["method"]
    # The keys ask for a nearly steady turn (keyed speeds 6, 7.6, 4.7°/frame): not a method whose speed
    # varies more than 1.5× that, nor one that stops between keys.
    assert rec["methods"][chosen]["speed_excess"] <= compare.STEADY_EXCESS
    assert t.sources[chosen].metrics["speed_ratio"] < 2.0
    worst = max(compare.ENGINE_METHODS, key=lambda n: t.sources[n].metrics["speed_ratio"])
    assert chosen != worst and not rec["no_difference"]
    assert chosen == "SLERP" and "not smooth at keys" in rec["text"]
    assert rec["text"].startswith("Slerp: passes the keys"), rec["text"]  # the label; the field keeps SLERP
    assert "; not: " in rec["text"] and "SPLINE_C2" not in rec["text"] and "SQUAD" not in rec["text"], rec["text"]


def test_dense_motion_capture_says_no_difference_or_picks_a_steady_method(linear_keys):
    # Keys on every frame of a smooth turn with capture noise: the methods differ by less than the
    # samples can show.
    rng = np.random.default_rng(3)
    keys = {}
    for f in range(1, 121):
        angle = 40 * math.sin(f / 15.0) + rng.normal(0, 0.3)
        keys[f] = tuple(Quaternion((0.3, 0.9, 0.3), math.radians(angle)))
    t, rec = recommendation(linear_keys, "Capture", "QUATERNION", keys)
    if not rec["no_difference"]:
        assert rec["methods"][rec["method"]]["speed_excess"] <= compare.STEADY_EXCESS
    else:
        assert rec["agreement_deg"] <= rec["sampling_error_deg"]
        assert "no difference" in rec["text"]


def test_demo_motion_capture_never_recommends_a_method_that_stops(linear_keys):
    bvh = os.path.join(SHARED, "data", "mocap", "mocapbank.bvh")
    if not os.path.exists(bvh):
        pytest.skip("%s is not present" % bvh)
    import sys
    sys.path.insert(0, os.path.join(ROOT, "build_scripts"))
    import demo_scene
    rig = demo_scene.import_bvh(bvh)
    bones = [targets.Target(rig, name) for name in ("LeftAnkle", "LeftWrist", "Chest")]
    report = compare.compare(bones, compare.CompareSettings(subframes=4))
    for t in report.targets:
        rec = t.recommendation
        assert rec["no_difference"] or rec["methods"][rec["method"]]["eligible"], t.name
        assert t.sources[rec["method"]].metrics["speed_ratio"] < compare.STOP_RATIO, t.name


# ---- the path rule ---------------------------------------------------------------------------------------------

HOLDS = {1: (0, 0, 0), 11: (0, 0, 0), 21: (0, 0, 120), 31: (0, 0, 120), 41: (0, 0, 0), 51: (0, 0, 0)}


def test_compare_reports_path_rule_breaks_with_target_frames_and_ratio(linear_keys, tmp_path):
    obj = keyed_object(linear_keys, "Holds", "XYZ", HOLDS)
    report = compare.compare([targets.Target(obj)])
    t = report.targets[0]
    assert {b.method for b in t.path_rule} == {"SPLINE_C2"}  # the clamped methods obey the rule
    frames = [(b.frame_start, b.frame_end) for b in t.path_rule]
    assert (21.0, 31.0) in frames
    hold = next(b for b in t.path_rule if (b.frame_start, b.frame_end) == (21.0, 31.0))
    assert math.degrees(hold.arc) < 1e-6 and math.degrees(hold.path) > 10.0
    assert not math.isfinite(hold.ratio)
    lines = report.table_lines()
    assert any(line.startswith("  path rule: Holds: C2 Spline, frames 21-31: path") for line in lines), lines
    path, _ = compare.write_report(report, str(tmp_path / "r.json"))
    with open(path) as f:
        data = json.load(f)
    assert schema_errors(data) == []
    entry = next(b for b in data["targets"][0]["path_rule"] if b["frame_start"] == 21.0)
    assert entry["method"] == "SPLINE_C2" and entry["ratio"] is None and entry["path_deg"] > 10


def test_bake_notes_name_the_segments_that_break_the_path_rule(linear_keys):
    obj = keyed_object(linear_keys, "Holds", "XYZ", {1: (0, 0, 0), 11: (0, 0, 170), 21: (0, 0, 170), 31: (0, 0, 0)})
    result = bake.bake([targets.Target(obj)], bake.BakeSettings(method="SPLINE_C2"))
    notes = [n for n in result.notes() if n.startswith("path rule:")]
    assert notes == [n for n in notes if "Holds: C2 Spline, frames 11-21: path" in n] and len(notes) == 1
    obj2 = keyed_object(linear_keys, "Clamped", "XYZ", {1: (0, 0, 0), 11: (0, 0, 170), 21: (0, 0, 170), 31: (0, 0, 0)})
    result = bake.bake([targets.Target(obj2)], bake.BakeSettings(method="CATMULL_ROM"))
    assert not [n for n in result.notes() if n.startswith("path rule:")]


def test_a_fitted_target_is_compared_through_the_animators_keys(linear_keys):
    """After a fit, the keys the fit generated are not key frames: the comparison (like the bake and the
    trails) builds the methods through the animator's keys, so it finds the same keys and the same
    curves as before the fit, and no method "stops" at a generated key."""
    s, c = math.sin(math.radians(60)), math.cos(math.radians(60))
    keys = {1: (1, 0, 0, 0), 21: (c, s, 0, 0), 41: (-c, 0, -s, 0), 61: (0.5, 0.5, 0.5, 0.5)}
    obj = keyed_object(linear_keys, "Fitted", "QUATERNION", keys)
    target = targets.Target(obj)
    before = fit.source_keys(target)
    result = fit.fit([target], fit.FitSettings(method="SQUAD", tolerance=0.05))
    assert result.fitted[0].generated_keys > 0  # the fit generated keys between the animator's
    assert len(targets.read_rotation_keys(target).frames) > len(keys)
    after = fit.source_keys(target)
    np.testing.assert_array_equal(after.frames, before.frames)
    np.testing.assert_allclose(np.abs(after.values), np.abs(before.values), atol=1e-6)
    report = compare.compare([target], compare.CompareSettings())
    assert list(report.targets[0].key_frames) == [1.0, 21.0, 41.0, 61.0]
