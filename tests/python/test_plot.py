"""The comparison plot's drawing (addon/quatcurve_blender/plot.py), outside Blender: pixel values
checked against the data — a series' line lies at the row its value maps to, in its colour; axes,
grid and legend in theirs; the PNG encoding read back with zlib. Images are Blender's
(tests/blender/test_compare.py reads the PNGs and images back through Blender).
"""

import importlib.util
import os
import struct
import zlib

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
_spec = importlib.util.spec_from_file_location(
    "quatcurve_plot", os.path.join(ROOT, "addon", "quatcurve_blender", "plot.py"))
plot = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(plot)

NAMES = ["BLENDER", "BLENDER_EULER_XYZ", "BLENDER_QUATERNION", "SLERP", "SQUAD", "CATMULL_ROM", "TCB",
         "SPLINE_C2", "NLERP"]


def example_series():
    frames = np.linspace(1.0, 61.0, 241)
    mid = 0.5 * (frames[1:] + frames[:-1])
    series = []
    for i, name in enumerate(NAMES):
        series.append({
            "name": name,
            "speed_frames": mid,
            "speed": 2.0 + i * 0.4 + np.sin(mid / 6.0 + i),
            "frames": frames,
            "deviation": (i + 1) * np.abs(np.sin(frames / 20.0)),
        })
    return series


@pytest.fixture(scope="module")
def pixels():
    return plot.render_comparison("Cube", example_series(), key_frames=[1, 21, 41, 61])


def colour_at(pixels, x, y):
    return tuple(int(v) for v in pixels[int(y), int(x), :3])


def test_size_opacity_and_background(pixels):
    assert pixels.shape == (plot.HEIGHT, plot.WIDTH, 4) == (800, 1200, 4) and pixels.dtype == np.uint8
    assert (pixels[..., 3] == 255).all()
    assert colour_at(pixels, 5, 5) == plot.BACKGROUND  # the margin
    ink = (pixels[..., :3] != plot.BACKGROUND).any(axis=2)
    assert 0.02 < ink.mean() < 0.5


def flat_series(values, names=None):
    """One series per value, each constant (speed and deviation) over frames 0..100."""
    frames = np.linspace(0.0, 100.0, 401)
    mid = 0.5 * (frames[1:] + frames[:-1])
    return [{"name": (names or ["S%d" % i for i in range(len(values))])[i], "speed_frames": mid,
             "speed": np.full(len(mid), v), "frames": frames, "deviation": np.full(len(frames), v / 2)}
            for i, v in enumerate(values)]


def test_a_constant_series_lies_on_the_row_its_value_maps_to_in_its_colour():
    series = flat_series([2.0, 7.0])
    pixels = plot.render_comparison("flat", series)
    speed, deviation = plot.make_panels(None, series)
    for i, value in enumerate([2.0, 7.0]):
        colour = plot.PALETTE[i]
        for panel, v in ((speed, value), (deviation, value / 2)):
            for frame in (10.0, 50.0, 90.0):
                x, y = panel.to_pixels(frame, v)
                # Width 2 centred on y: the pixel holding y is fully covered, 3 rows away nothing is.
                assert colour_at(pixels, x, y) == colour, (i, frame)
                assert colour_at(pixels, x, y - 3) != colour and colour_at(pixels, x, y + 3) != colour
    # 7 is the largest value: the speed range ends at the next round tick above 7 × 1.05.
    assert speed.y_lo == 0.0 and speed.y_hi == 8.0
    x, y = speed.to_pixels(0.0, 0.0)
    assert (x, y) == (plot.PLOT_LEFT, plot.SPEED_ROWS[1])


def test_a_ramp_is_drawn_at_every_column_at_its_value():
    frames = np.linspace(0.0, 100.0, 11)  # coarse: the line is interpolated between the points
    series = [{"name": "ramp", "colour": (200, 0, 0), "speed_frames": frames, "speed": frames / 10.0,
               "frames": frames, "deviation": np.zeros_like(frames)}]
    pixels = plot.render_comparison("ramp", series)
    speed, _ = plot.make_panels(None, series)
    for frame in np.linspace(3.0, 97.0, 40):
        x, y = speed.to_pixels(frame, frame / 10.0)
        assert colour_at(pixels, x, y) == (200, 0, 0), frame


def test_axes_grid_and_legend_colours(pixels):
    speed, deviation = plot.make_panels(None, example_series(), key_frames=[1, 21, 41, 61])
    for panel in (speed, deviation):
        left, top, right, bottom = panel.box
        assert colour_at(pixels, (left + right) // 2, top) == plot.INK        # the frame
        assert colour_at(pixels, left, (top + bottom) // 2) == plot.INK
        assert colour_at(pixels, left - 3, round(float(panel.to_pixels(0, panel.y_ticks[1])[1]))) == plot.INK  # a tick
    # A grid line at a y tick, away from the curves: right of the last key line, inside the frame.
    x, y = speed.to_pixels(speed.x_hi, speed.y_ticks[-2])
    assert colour_at(pixels, x - 2, y) in (plot.GRID, plot.INK)
    for i, name in enumerate(NAMES):  # the swatches: 28 × 12 pixels of the series' colour
        y = 90 + 34 + i * 22
        swatch = pixels[y:y + 12, plot.LEGEND_LEFT + 12:plot.LEGEND_LEFT + 40, :3]
        assert (swatch == plot.PALETTE[i]).all(), name


def test_every_series_colour_appears_in_both_panels(pixels):
    rgb = pixels[..., :3]
    columns = slice(plot.PLOT_LEFT, plot.PLOT_RIGHT)
    for i, name in enumerate(NAMES):
        hit = (rgb == np.array(plot.PALETTE[i], np.uint8)).all(axis=2)
        assert hit[slice(*plot.SPEED_ROWS), columns].sum() > 100, name
        assert hit[slice(*plot.DEVIATION_ROWS), columns].sum() > 100, name


def test_text_uses_the_embedded_font():
    mask = plot.text_mask("A\u00b0", scale=2)
    assert mask.shape == (26, 28)
    assert mask[:, :14].sum() > 20 and mask[:, 14:].sum() > 8
    assert not plot.text_mask(" ").any()
    np.testing.assert_array_equal(plot.text_mask("\u2603"), plot.text_mask("?"))  # unknown → '?'


def test_nice_ticks_and_labels():
    ticks = plot.nice_ticks(0.0, 17.3)
    assert ticks[0] == 0.0 and ticks[-1] >= 17.3 and len(ticks) <= 8
    assert [plot.format_tick(v, 2.5) for v in (0.0, 2.5, 5.0)] == ["0", "2.5", "5.0"]


def test_non_finite_values_break_lines_instead_of_failing():
    series = example_series()[:2]
    series[0]["speed"] = series[0]["speed"].copy()
    series[0]["speed"][10:20] = np.nan
    series[1]["deviation"] = np.full_like(series[1]["deviation"], np.inf)
    pixels = plot.render_comparison("gaps", series)
    assert pixels.shape == (800, 1200, 4)
    speed, deviation = plot.make_panels(None, series)
    gap = speed.to_pixels(series[0]["speed_frames"][[11, 18]], 0)[0]  # well inside the NaN run
    columns = pixels[slice(*plot.SPEED_ROWS), int(gap[0]) + 2:int(gap[1]) - 1, :3]
    assert not (columns == plot.PALETTE[0]).all(axis=2).any()  # the line is broken there
    inside = pixels[slice(*plot.DEVIATION_ROWS), plot.PLOT_LEFT + 1:plot.PLOT_RIGHT, :3]
    assert not (inside == plot.PALETTE[1]).all(axis=2).any()  # all-inf: nothing drawn


def test_legend_names_coinciding_series():
    series = example_series()[:3]
    series[2] = dict(series[0], name="COPY")
    assert plot.legend_labels(series) == ["BLENDER", "BLENDER_EULER_XYZ", "COPY =BLENDER"]


def test_legend_tells_series_within_a_millionth_of_a_degree_and_nan_alike():
    series = example_series()[:3]
    series[1] = dict(series[0], name="NEAR", speed=series[0]["speed"] + 0.9e-6)
    series[2] = dict(series[0], name="FAR", deviation=series[0]["deviation"] + 1.1e-6)
    assert plot.legend_labels(series) == ["BLENDER", "NEAR =BLENDER", "FAR"]
    gaps = [dict(s, speed=np.where(np.arange(len(s["speed"])) % 7 == 0, np.nan, s["speed"])) for s in series[:2]]
    gaps[1]["name"] = "GAPS"
    assert plot.legend_labels(gaps) == ["BLENDER", "GAPS =BLENDER"]
    gaps[1]["speed"] = gaps[1]["speed"].copy()
    gaps[1]["speed"][7] = 1.0  # a value where the other has NaN
    assert plot.legend_labels(gaps) == ["BLENDER", "GAPS"]


def test_png_bytes_hold_the_pixels():
    rng = np.random.default_rng(7)
    pixels = rng.integers(0, 256, size=(5, 3, 4), dtype=np.uint8)
    data = plot.png_bytes(pixels)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    chunks, at = {}, 8
    while at < len(data):
        length, tag = struct.unpack(">I4s", data[at:at + 8])
        body = data[at + 8:at + 8 + length]
        assert struct.unpack(">I", data[at + 8 + length:at + 12 + length])[0] == zlib.crc32(tag + body)
        chunks[tag] = body
        at += 12 + length
    assert list(chunks) == [b"IHDR", b"IDAT", b"IEND"]
    assert struct.unpack(">IIBBBBB", chunks[b"IHDR"]) == (3, 5, 8, 6, 0, 0, 0)
    rows = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), np.uint8).reshape(5, 1 + 3 * 4)
    assert (rows[:, 0] == 0).all()  # no filter
    np.testing.assert_array_equal(rows[:, 1:].reshape(5, 3, 4), pixels)
    with pytest.raises(ValueError, match="RGBA"):
        plot.png_bytes(pixels[:, :, :3])
