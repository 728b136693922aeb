"""Comparison plots drawn into a numpy array: Blender's bundled Python has no matplotlib, and in
background mode Blender draws no lines or text into an image (gpu and blf drawing need a GPU
context; blf draws into image buffers only from 4.x on).

`render_comparison` draws two panels — angular speed over frames per source, and the deviation from
SLERP over frames per source — with axes, tick labels, titles, axis labels and a legend with colour
swatches, into an RGBA uint8 array of the documented fixed size WIDTH × HEIGHT (1200 × 800, rows top
to bottom). `png_bytes` encodes such an array as a PNG file (8-bit RGBA, zlib), which compare.py writes
and Blender loads as the image datablock; without a file, compare.py hands the array to an image
datablock (`image.pixels.foreach_set`).

Text uses the 7×13 "fixed" bitmap font of the X Window System (misc-fixed, public domain: "Public
domain font. Share and enjoy."), embedded below for printable ASCII plus the degree sign, drawn at
scale 1 for ticks and legend and 2 for the title. Series are functions of the frame, so a line is
drawn a pixel column at a time, every column at once (Canvas.trace): the polyline's vertical extent
over the column, anti-aliased at its ends.
"""

import struct
import zlib

import numpy as np

WIDTH, HEIGHT = 1200, 800
# Layout (pixels): both panels span PLOT_LEFT..PLOT_RIGHT; the speed panel's plot area is rows
# SPEED_ROWS, the deviation panel's DEVIATION_ROWS; the legend starts at LEGEND_LEFT.
LEGEND_LEFT = WIDTH - 270
PLOT_LEFT, PLOT_RIGHT = 100, LEGEND_LEFT - 30
SPEED_ROWS = (90, 380)
DEVIATION_ROWS = (470, 740)

# ---- colours ----------------------------------------------------------------------------------------
BACKGROUND = (255, 255, 255)
INK = (33, 33, 33)
GRID = (225, 225, 225)
KEY_LINE = (170, 170, 170)
# Distinct, print-safe colours (tab20's strong half first, then its light half), one per source in
# order; pure grey is left out so lines never look like the grid. Sources beyond 20 reuse them.
PALETTE = (
    (31, 119, 180), (214, 39, 40), (44, 160, 44), (255, 127, 14), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (23, 190, 207), (188, 189, 34), (0, 0, 0),
    (174, 199, 232), (255, 152, 150), (152, 223, 138), (255, 187, 120), (197, 176, 213),
    (196, 156, 148), (247, 182, 210), (158, 218, 229), (219, 219, 141), (90, 90, 160),
)

# ---- font ---------------------------------------------------------------------------------------------
GLYPH_W, GLYPH_H = 7, 13
# 13 row bytes per glyph for ASCII 32..126 (bit 6 = leftmost column), then the degree sign.
_FONT_HEX = (
    "00000000000000000000000000000008080808080808000800000000141414000000000000000000000014143e143e1414000000"
    "000000081e281c0a3c080000000000225224080810244a44000000000000304848304a443a000000000808080000000000000000"
    "00000408081010100808040000000010080804040408081000000000000024187e1824000000000000000008083e080800000000"
    "0000000000000000001c1820000000000000003e000000000000000000000000000000081c080000000202040408101020200000"
    "00001824424242424224180000000008182808080808083e000000003c424202041820407e000000007e0204081c0202423c0000"
    "0000040c142444447e0404000000007e40405c620202423c000000001c2040405c6242423c000000007e02040808101020200000"
    "00003c4242423c4242423c000000003c4242463a02020438000000000000081c080000081c080000000000081c0800001c182000"
    "0000020408102010080402000000000000007e00007e000000000000201008040204081020000000003c42420204080800080000"
    "00003c42424e52564a403c0000000018244242427e424242000000007c2222223c2222227c000000003c424040404040423c0000"
    "00007c222222222222227c000000007e404040784040407e000000007e4040407840404040000000003c424040404e42463a0000"
    "0000424242427e42424242000000003e080808080808083e000000000e0404040404044438000000004244485060504844420000"
    "000040404040404040407e000000004266665a5a4242424200000000424262524a46424242000000003c424242424242423c0000"
    "00007c4242427c40404040000000003c4242424242524a3c020000007c4242427c50484442000000003c4240403c0202423c0000"
    "00003e08080808080808080000000042424242424242423c0000000042424224242418181800000000424242425a5a6666420000"
    "000042422424182424424200000000222214140808080808000000007e020408181020407e0000003c2020202020202020203c00"
    "00002020101008040402020000003c0404040404040404043c000000081422000000000000000000000000000000000000007e00"
    "0010080000000000000000000000000000003c023e42463a000000004040405c624242625c000000000000003c424040423c0000"
    "00000202023a464242463a000000000000003c427e40423c000000001c2220207820202020000000000000003a444438403c423c"
    "00004040405c62424242420000000000080018080808083e00000000000200060202020222221c00004040404448704844420000"
    "000018080808080808083e00000000000000342a2a2a2a22000000000000005c6242424242000000000000003c424242423c0000"
    "00000000005c6242625c40404000000000003a4642463a02020200000000005c2220202020000000000000003c42300c423c0000"
    "000000202078202020221c0000000000000042424242463a000000000000002222221414080000000000000022222a2a2a140000"
    "000000000042241818244200000000000000424242463a02423c00000000007e040810207e0000000e1010100830081010100e00"
    "00000808080808080808080000003804040408060804040438000000122a240000000000000000"
    "00001824241800000000000000"
)
_FONT = np.unpackbits(np.frombuffer(bytes.fromhex(_FONT_HEX), np.uint8).reshape(-1, GLYPH_H, 1),
                      axis=2)[:, :, 1:].astype(bool)  # (96, 13, 7)
_DEGREE_INDEX = 95


def _glyph(ch):
    code = ord(ch)
    if 32 <= code <= 126:
        return _FONT[code - 32]
    if ch == "\u00b0":
        return _FONT[_DEGREE_INDEX]
    return _FONT[ord("?") - 32]


def text_mask(text, scale=1):
    """Boolean mask (13·scale, 7·scale·len) of `text` in the embedded font."""
    if not text:
        return np.zeros((GLYPH_H * scale, 0), bool)
    mask = np.concatenate([_glyph(ch) for ch in text], axis=1)
    if scale > 1:
        mask = mask.repeat(scale, axis=0).repeat(scale, axis=1)
    return mask


def text_width(text, scale=1):
    return GLYPH_W * scale * len(text)


# ---- canvas -------------------------------------------------------------------------------------------
def _rgba_word(colour):
    """The opaque pixel (r, g, b, 255) as the uint32 its four bytes make in memory."""
    return int(np.frombuffer(bytes(tuple(colour) + (255,)), np.uint32)[0])


class Canvas:
    """RGBA uint8 pixels (height, width, 4), rows top to bottom, opaque."""

    def __init__(self, width=WIDTH, height=HEIGHT, background=BACKGROUND):
        self.pixels = np.empty((height, width, 4), np.uint8)
        # One 32-bit word per pixel: a plain fill, not four strided byte planes.
        self.pixels.view(np.uint32).fill(_rgba_word(background))

    @property
    def width(self):
        return self.pixels.shape[1]

    @property
    def height(self):
        return self.pixels.shape[0]

    def fill_rect(self, x0, y0, x1, y1, colour):
        """Fills the pixels x0 ≤ x < x1, y0 ≤ y < y1 (clipped)."""
        x0, x1 = max(int(x0), 0), min(int(x1), self.width)
        y0, y1 = max(int(y0), 0), min(int(y1), self.height)
        if x0 < x1 and y0 < y1:
            self.pixels[y0:y1, x0:x1, :3] = colour

    def blend(self, x0, y0, coverage, colour):
        """Mixes `colour` over the pixels under `coverage` (floats 0..1) placed at (x0, y0), clipped;
        only the covered pixels are touched."""
        h, w = coverage.shape
        cx0, cy0 = max(x0, 0), max(y0, 0)
        cx1, cy1 = min(x0 + w, self.width), min(y0 + h, self.height)
        if cx0 >= cx1 or cy0 >= cy1:
            return
        a = coverage[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]
        rows, cols = np.nonzero(a > 0)
        self._mix((rows + cy0) * self.width + (cols + cx0), a[rows, cols], colour)

    def blend_pixels(self, rows, cols, coverage, colour):
        """Mixes `colour` over the pixels (rows[i], cols[i]) by coverage[i] (0..1); each pixel once."""
        keep = coverage > 0
        self._mix(rows[keep] * self.width + cols[keep], coverage[keep], colour)

    def _mix(self, index, coverage, colour):
        """pixel = rint(pixel·(1 − a) + colour·a) for the pixels at flat `index` (row·width + column),
        a = coverage (float32 arithmetic); whole pixels are gathered and scattered (alpha stays)."""
        # Fully covered pixels (a line's inside, text) become the colour itself, as the formula gives
        # (pixel·0 + colour·1): one 32-bit word each; only the partly covered ones are mixed.
        full = coverage >= 1.0
        words = self.pixels.reshape(-1).view(np.uint32)
        words[index[full]] = _rgba_word(colour)
        index, coverage = index[~full], coverage[~full]
        flat = self.pixels.reshape(-1, 4)
        a = coverage.astype(np.float32)[:, None]
        under = flat[index]
        under[:, :3] = np.rint(under[:, :3] * (1.0 - a) + np.asarray(colour, np.float32) * a).astype(np.uint8)
        flat[index] = under

    def text(self, x, y, text, colour=INK, scale=1, align="left", valign="top", rotate=False):
        """Draws `text` with its anchor at (x, y): align left/center/right, valign top/middle/bottom
        (of the unrotated text box). rotate=True turns it 90° counter-clockwise (reads bottom to top);
        then align/valign refer to the rotated box's horizontal/vertical extent."""
        mask = text_mask(text, scale)
        if rotate:
            mask = np.rot90(mask)
        h, w = mask.shape
        x0 = int(round(x - {"left": 0, "center": w / 2, "right": w}[align]))
        y0 = int(round(y - {"top": 0, "middle": h / 2, "bottom": h}[valign]))
        self.blend(x0, y0, mask.astype(float), colour)

    def trace(self, xs, ys, colour, width=2.0, rows=None):
        """A line of `width` pixels through (xs, ys) in pixel coordinates, xs increasing (a function of
        x, as every series of the plot is); NaN or inf breaks it. Drawn column by column, all columns
        at once: each pixel column c takes the vertical span of the polyline over the window
        [c + 0.5 − h, c + 0.5 + h] (h = width / 2, at least half a pixel) widened by width / 2 above and
        below, with the span's end pixels covered by their fraction (anti-aliased vertically). A flat
        line is `width` pixels tall, a steep one about `width` pixels wide. rows = (top, bottom)
        clips the span to those pixel rows (a value beyond them is drawn to the edge)."""
        xs, ys = np.asarray(xs, float), np.asarray(ys, float)
        ok = np.isfinite(xs) & np.isfinite(ys)
        if not ok.any():
            return
        half = max(width / 2.0, 0.5)
        idx = np.flatnonzero(ok)
        # Pieces: the segments between consecutive finite points (neighbours in the series: no
        # non-finite point between them), and every finite point on its own (so a lone point is drawn
        # too); each piece spans [xa, xb] with ya, yb at its ends.
        seg = idx[:-1][np.diff(idx) == 1]
        xa = np.concatenate([xs[idx], xs[seg]])
        xb = np.concatenate([xs[idx], xs[seg + 1]])
        ya = np.concatenate([ys[idx], ys[seg]])
        yb = np.concatenate([ys[idx], ys[seg + 1]])
        lo_x, hi_x = np.minimum(xa, xb), np.maximum(xa, xb)
        dx = xb - xa
        slope = np.divide(yb - ya, dx, out=np.zeros_like(dx), where=dx != 0)
        # Columns whose window [c + 0.5 − half, c + 0.5 + half] meets the piece.
        first = np.maximum(np.ceil(lo_x - 0.5 - half), 0).astype(np.int64)
        last = np.minimum(np.floor(hi_x - 0.5 + half), self.width - 1).astype(np.int64)
        count = np.maximum(last - first + 1, 0)
        piece = np.repeat(np.arange(len(xa)), count)
        if piece.size == 0:
            return
        col = first[piece] + (np.arange(piece.size) - np.repeat(np.cumsum(count) - count, count))
        # The piece's y at the window's ends (clipped to the piece): its extent inside the window.
        lo_x, hi_x, xa, ya, slope = lo_x[piece], hi_x[piece], xa[piece], ya[piece], slope[piece]
        y0 = ya + slope * (np.minimum(np.maximum(col + 0.5 - half, lo_x), hi_x) - xa)
        y1 = ya + slope * (np.minimum(np.maximum(col + 0.5 + half, lo_x), hi_x) - xa)
        # Per column, the least and greatest y of its pieces (sorted by column, reduced per run).
        order = np.argsort(col, kind="stable")
        col = col[order]
        starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
        cols = col[starts]
        span_lo = np.minimum.reduceat(np.minimum(y0, y1)[order], starts)
        span_hi = np.maximum.reduceat(np.maximum(y0, y1)[order], starts)
        top = (rows[0] if rows else 0)
        bottom = (rows[1] if rows else self.height)
        lo = np.maximum(span_lo - width / 2.0, top)
        hi = np.minimum(span_hi + width / 2.0, bottom)
        # The pixels of each column's span only (a sparse list), each covered by its overlap with it.
        first_row = np.maximum(np.floor(lo), 0).astype(np.int64)
        end_row = np.minimum(np.ceil(hi), self.height).astype(np.int64)
        count = np.maximum(end_row - first_row, 0)
        which = np.repeat(np.arange(len(cols)), count)
        r = first_row[which] + (np.arange(which.size) - np.repeat(np.cumsum(count) - count, count))
        coverage = np.clip(np.minimum(r + 1.0, hi[which]) - np.maximum(r, lo[which]), 0.0, 1.0)
        self.blend_pixels(r, cols[which], coverage, colour)


# ---- axes -----------------------------------------------------------------------------------------------
def nice_ticks(lo, hi, count=6):
    """Round tick values (1, 2, 2.5 or 5 × 10^k steps) covering [lo, hi] with about `count` ticks."""
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / max(count - 1, 1)
    power = 10.0 ** np.floor(np.log10(raw))
    step = next(m * power for m in (1, 2, 2.5, 5, 10) if m * power >= raw * 0.999)
    first = np.floor(lo / step + 1e-9) * step
    last = np.ceil(hi / step - 1e-9) * step
    return np.arange(round((last - first) / step) + 1) * step + first


def format_tick(value, step):
    """Tick label with as many decimals as the step needs."""
    decimals = max(0, int(-np.floor(np.log10(step) + 1e-9))) if step > 0 else 0
    if step * 10 ** decimals % 1 > 1e-6:  # 2.5 × 10^k needs one more
        decimals += 1
    text = "%.*f" % (decimals, value)
    return "0" if text.strip("-0.") == "" else text


class Panel:
    """One plot area with data limits; maps data (x, y) to pixel coordinates."""

    def __init__(self, canvas, box, x_range, y_range, title, x_label, y_label):
        self.canvas, self.box = canvas, box  # box = (left, top, right, bottom) of the plot area
        # Frames span exactly the data (ticks inside it); values extend to the next round tick.
        self.x_lo, self.x_hi = float(x_range[0]), float(x_range[1])
        ticks = nice_ticks(self.x_lo, self.x_hi, count=10)
        self.x_step = ticks[1] - ticks[0]
        self.x_ticks = ticks[(ticks >= self.x_lo - 1e-9 * self.x_step) & (ticks <= self.x_hi + 1e-9 * self.x_step)]
        self.y_ticks = nice_ticks(*y_range, count=6)
        self.y_step = self.y_ticks[1] - self.y_ticks[0]
        self.y_lo, self.y_hi = self.y_ticks[0], self.y_ticks[-1]
        self.title, self.x_label, self.y_label = title, x_label, y_label

    def to_pixels(self, x, y):
        left, top, right, bottom = self.box
        px = left + (np.asarray(x, float) - self.x_lo) / (self.x_hi - self.x_lo) * (right - left)
        py = bottom - (np.asarray(y, float) - self.y_lo) / (self.y_hi - self.y_lo) * (bottom - top)
        return px, py

    def draw_frame(self, key_frames=()):
        c = self.canvas
        left, top, right, bottom = self.box
        for xv in self.x_ticks:
            px = int(round(float(self.to_pixels(xv, 0)[0])))
            c.fill_rect(px, top, px + 1, bottom, GRID)
            c.fill_rect(px, bottom, px + 1, bottom + 5, INK)
            c.text(px, bottom + 8, format_tick(xv, self.x_step), align="center")
        for yv in self.y_ticks:
            py = int(round(float(self.to_pixels(0, yv)[1])))
            c.fill_rect(left, py, right, py + 1, GRID)
            c.fill_rect(left - 5, py, left, py + 1, INK)
            c.text(left - 8, py, format_tick(yv, self.y_step), align="right", valign="middle")
        # Dashed vertical lines at the keys, unless they would hatch the panel (a key every frame,
        # as in motion capture): at most one line per 12 pixels on average.
        if len(key_frames) > (right - left) / 12:
            key_frames = ()
        dashes = np.arange(top, bottom)
        dashes = dashes[(dashes - top) % 8 < 4]  # 4 pixels on, 4 off
        for kf in key_frames:
            px = int(round(float(self.to_pixels(kf, 0)[0])))
            if 0 <= px < c.width:
                c.pixels[dashes, px, :3] = KEY_LINE
        c.fill_rect(left, top, right + 1, top + 1, INK)
        c.fill_rect(left, bottom, right + 1, bottom + 1, INK)
        c.fill_rect(left, top, left + 1, bottom, INK)
        c.fill_rect(right, top, right + 1, bottom, INK)
        c.text((left + right) / 2, top - 8, self.title, valign="bottom", align="center")
        c.text((left + right) / 2, bottom + 26, self.x_label, align="center")
        c.text(left - 62, (top + bottom) / 2, self.y_label, rotate=True, align="center", valign="middle")

    def draw_series(self, xs, ys, colour, width=2.0):
        px, py = self.to_pixels(xs, ys)
        left, top, right, bottom = self.box
        # Clipped to the plot area: a value beyond the range runs along its edge.
        self.canvas.trace(px, py, colour, width, rows=(top, bottom + 1))


# ---- the comparison figure --------------------------------------------------------------------------------
def _finite_max(arrays, floor):
    values = [np.max(a[np.isfinite(a)]) for a in arrays if np.any(np.isfinite(a))]
    return max(values + [floor])


def legend_labels(series):
    """Legend text per series: its name, plus "= NAME" when its curves coincide with an earlier
    series' (within 1e-6°), which it then hides — so a reader knows where the hidden one went."""
    labels = []
    for i, s in enumerate(series):
        same = next((t["name"] for t in series[:i] if _same_curves(s, t)), None)
        labels.append(s["name"] if same is None else "%s =%s" % (s["name"], same))
    return labels


def _same_curves(a, b):
    """Whether two series coincide within 1e-6 at every point (NaN matching NaN, inf the same inf):
    np.allclose(rtol=0, atol=1e-6, equal_nan=True), the values first (the frames are usually one
    shared array) and without allclose's overhead (a figure compares every pair of its series)."""
    for key in ("speed", "deviation", "speed_frames", "frames"):
        if a[key] is b[key]:
            continue
        x, y = np.asarray(a[key], float), np.asarray(b[key], float)
        if x.shape != y.shape:
            return False
        with np.errstate(invalid="ignore"):
            close = (np.abs(x - y) <= 1e-6) | (x == y) | (np.isnan(x) & np.isnan(y))
        if not close.all():
            return False
    return True


PANEL_TITLES = (("Angular speed", "speed (\u00b0/frame)"), ("Deviation from SLERP", "deviation (\u00b0)"))


def make_panels(canvas, series, key_frames=(), titles=PANEL_TITLES):
    """(speed panel, deviation panel) of the figure for `series`: their pixel boxes and data ranges
    (Panel.to_pixels maps frames and values to pixel coordinates; canvas may be None to ask only that).
    titles: each panel's (title, y label)."""
    left, right = PLOT_LEFT, PLOT_RIGHT
    all_frames = [np.asarray(s["frames"], float) for s in series] + [np.asarray(key_frames, float)]
    finite_frames = np.concatenate([f[np.isfinite(f)] for f in all_frames] + [np.zeros(0)])
    x_range = (finite_frames.min(), finite_frames.max()) if finite_frames.size else (0.0, 1.0)
    if x_range[1] <= x_range[0]:
        x_range = (x_range[0], x_range[0] + 1.0)
    speed_max = _finite_max([np.asarray(s["speed"], float) for s in series], 1e-3)
    deviation_max = _finite_max([np.asarray(s["deviation"], float) for s in series], 1e-3)
    return (
        Panel(canvas, (left, SPEED_ROWS[0], right, SPEED_ROWS[1]), x_range, (0.0, speed_max * 1.05),
              titles[0][0], "frame", titles[0][1]),
        Panel(canvas, (left, DEVIATION_ROWS[0], right, DEVIATION_ROWS[1]), x_range, (0.0, deviation_max * 1.05),
              titles[1][0], "frame", titles[1][1]),
    )


def render_comparison(title, series, key_frames=(), subtitle="", titles=PANEL_TITLES):
    """The comparison figure for one target as an RGBA uint8 array (HEIGHT, WIDTH, 4), rows top down.

    series: list of dicts, one per source, drawn in order with PALETTE colours unless "colour" is given:
      name            legend text
      speed_frames    (M,) frames of the speed samples (interval midpoints)
      speed           (M,) angular speed, degrees per frame
      frames          (N,) sample frames
      deviation       (N,) angle from the SLERP path, degrees
    key_frames: frames of the keys, drawn as dashed vertical lines in both panels.
    titles: each panel's (title, y label), the upper panel's first (other uses: another second panel).
    """
    canvas = Canvas()
    canvas.text(WIDTH / 2, 12, title, scale=2, align="center")
    if subtitle:
        canvas.text(WIDTH / 2, 44, subtitle, align="center")
    legend_left = LEGEND_LEFT
    panels = make_panels(canvas, series, key_frames, titles)
    for panel in panels:
        panel.draw_frame(key_frames)
    colours = []
    for i, s in enumerate(series):
        colour = tuple(s.get("colour", PALETTE[i % len(PALETTE)]))
        colours.append(colour)
        panels[0].draw_series(s["speed_frames"], s["speed"], colour)
        panels[1].draw_series(s["frames"], s["deviation"], colour)
    # Legend: a framed column to the right of the panels, one swatch and name per source.
    row_h = 22
    top = 90
    bottom = top + 16 + row_h * len(series) + 20
    canvas.fill_rect(legend_left, top, WIDTH - 14, top + 1, INK)
    canvas.fill_rect(legend_left, bottom, WIDTH - 14, bottom + 1, INK)
    canvas.fill_rect(legend_left, top, legend_left + 1, bottom, INK)
    canvas.fill_rect(WIDTH - 15, top, WIDTH - 14, bottom, INK)
    canvas.text(legend_left + 12, top + 10, "Sources")
    for i, (label, colour) in enumerate(zip(legend_labels(series), colours)):
        y = top + 34 + i * row_h
        canvas.fill_rect(legend_left + 12, y, legend_left + 40, y + 12, colour)
        fits = (WIDTH - 20 - legend_left - 50) // GLYPH_W
        canvas.text(legend_left + 50, y + 6, label if len(label) <= fits else label[:fits - 1] + "~",
                    valign="middle")
    if len(key_frames):
        y = bottom + 16
        for yy in range(y, y + 14, 8):
            canvas.fill_rect(legend_left + 26, yy, legend_left + 27, yy + 4, KEY_LINE)
        canvas.text(legend_left + 50, y + 7, "key frames", valign="middle")
    return canvas.pixels


# ---- PNG ------------------------------------------------------------------------------------------------
PNG_LEVEL = 1  # zlib level: as fast as Blender's own PNG writer (15 % compression), about the same size


def png_bytes(pixels):
    """The PNG file (bytes) of RGBA uint8 `pixels` (height, width, 4), rows top to bottom: 8 bits per
    channel, colour type 6 (RGBA), no filter, one zlib stream (level PNG_LEVEL). Any PNG reader gets
    the same bytes back (Blender's image loader included: its pixels are those bytes / 255).
    Touches no Blender data and releases the GIL while compressing, so worker threads may encode."""
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    height, width, channels = pixels.shape
    if channels != 4:
        raise ValueError("png_bytes: expected RGBA pixels (height, width, 4), got %s" % (pixels.shape,))
    rows = np.zeros((height, 1 + 4 * width), np.uint8)  # each row: filter type 0 (none), then its pixels
    rows[:, 1:] = pixels.reshape(height, -1)

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)  # 8-bit RGBA, deflate, no interlace
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), PNG_LEVEL)) + chunk(b"IEND", b""))
