"""The numpy-only comparison plot and its PNG encoder (addon/quatcurve_blender/plot.py), outside Blender.

The PNG is decoded here with zlib and struct directly, independently of plot.decode_png.
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


def read_png_with_zlib(data):
    """(width, height, rows) of an 8-bit RGBA PNG whose rows all use filter 0, checking every CRC."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, {}
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        assert struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])[0] == zlib.crc32(kind + body)
        chunks.setdefault(kind, []).append(body)
        pos += 12 + length
    assert pos == len(data) and b"IEND" in chunks
    width, height, depth, colour_type, _, _, interlace = struct.unpack(">IIBBBBB", chunks[b"IHDR"][0])
    assert (depth, colour_type, interlace) == (8, 6, 0)
    raw = np.frombuffer(zlib.decompress(b"".join(chunks[b"IDAT"])), np.uint8).reshape(height, 1 + 4 * width)
    assert (raw[:, 0] == 0).all()
    return width, height, raw[:, 1:].reshape(height, width, 4)


@pytest.fixture(scope="module")
def png(tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "compare.png"
    plot.write_png(str(path), plot.render_comparison("Cube", example_series(), key_frames=[1, 21, 41, 61]))
    return path.read_bytes()


def test_png_has_the_documented_size_and_is_not_blank(png):
    width, height, pixels = read_png_with_zlib(png)
    assert (width, height) == (plot.WIDTH, plot.HEIGHT) == (1200, 800)
    assert (pixels[..., 3] == 255).all()
    ink = (pixels[..., :3] != plot.BACKGROUND).any(axis=2)
    assert 0.02 < ink.mean() < 0.5
    assert len(np.unique(pixels.reshape(-1, 4), axis=0)) > 50  # anti-aliased lines, text, colours


def test_every_legend_colour_appears_in_both_panels(png):
    _, _, pixels = read_png_with_zlib(png)
    rgb = pixels[..., :3]
    columns = slice(plot.PLOT_LEFT, plot.PLOT_RIGHT)
    for i, name in enumerate(NAMES):
        colour = np.array(plot.PALETTE[i], np.uint8)
        hit = (rgb == colour).all(axis=2)
        assert hit[:, plot.LEGEND_LEFT:].sum() >= 28 * 12, name                   # the swatch
        assert hit[slice(*plot.SPEED_ROWS), columns].sum() > 100, name          # speed panel
        assert hit[slice(*plot.DEVIATION_ROWS), columns].sum() > 100, name      # deviation panel


def test_png_round_trip_through_decode_png(png):
    decoded = plot.decode_png(png)
    assert decoded.shape == (800, 1200, 4)
    _, _, pixels = read_png_with_zlib(png)
    np.testing.assert_array_equal(decoded, pixels)


def test_decode_png_undoes_every_filter():
    rng = np.random.default_rng(5)
    pixels = rng.integers(0, 256, size=(5, 7, 4), dtype=np.uint8)
    bpp, rows = 4, []
    prev = np.zeros(28, np.int32)
    for y, kind in enumerate([0, 1, 2, 3, 4]):
        cur = pixels[y].reshape(-1).astype(np.int32)
        left = np.concatenate([np.zeros(bpp, np.int32), cur[:-bpp]])
        upleft = np.concatenate([np.zeros(bpp, np.int32), prev[:-bpp]])
        if kind == 0:
            pred = np.zeros_like(cur)
        elif kind == 1:
            pred = left
        elif kind == 2:
            pred = prev
        elif kind == 3:
            pred = (left + prev) // 2
        else:
            p = left + prev - upleft
            pa, pb, pc = abs(p - left), abs(p - prev), abs(p - upleft)
            pred = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, prev, upleft))
        rows.append(bytes([kind]) + ((cur - pred) & 0xFF).astype(np.uint8).tobytes())
        prev = cur
    ihdr = struct.pack(">IIBBBBB", 7, 5, 8, 6, 0, 0, 0)
    data = (b"\x89PNG\r\n\x1a\n" + plot._chunk(b"IHDR", ihdr) +
            plot._chunk(b"IDAT", zlib.compress(b"".join(rows))) + plot._chunk(b"IEND", b""))
    np.testing.assert_array_equal(plot.decode_png(data), pixels)


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


def test_legend_names_coinciding_series():
    series = example_series()[:3]
    series[2] = dict(series[0], name="COPY")
    assert plot.legend_labels(series) == ["BLENDER", "BLENDER_EULER_XYZ", "COPY =BLENDER"]
