"""The 2-D overlay of a video frame (PIL): text, legend, colour bar, inset plot, run identity.

Layout of one panel (``h`` px high, text size ``s = max(10, round(h / 30))`` px):

- top left: the title (1.25 s), the time ``t = 600.0 s (10.0 min)``, then one line per overlay
  series, ``name = value unit`` (:func:`format_value`), and, once the run has ended (a run that
  stopped early holds its last record), why it ended in orange (``structure failed at 646 s:
  strut 1330 strain 0.501 > 0.5``, :func:`magsail_mj.render.ending.end_reason`);
- top right, below the title row: the legend, one row per colour shown (:class:`LegendEntry`:
  one to three swatches and a text);
- right, below the legend: the colour bar of the node heights, its caption and its values with
  units;
- lower left: the inset plot (one series' history up to the frame's time), and under it
  "×k exaggerated" when the out-of-plane motion is magnified;
- bottom centre: the panel label (side-by-side comparisons);
- bottom right: the run's identity, ``scenario <name> · config <first 12 hex digits of the
  config hash>``.

:func:`overlay_boxes` gives the boxes these parts cover, and :func:`free_rectangles` the largest
rectangles clear of them, where the renderer frames the structure.

Units of the printed values come from the series' name suffix
(:func:`magsail_mj.records.units_of`), degrees as ``°``; lengths
in metres are printed with an SI prefix (µm, mm, m).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from magsail_mj.records import units_of

__all__ = [
    "ColourBar",
    "Inset",
    "LegendEntry",
    "PanelText",
    "colormap",
    "draw_overlay",
    "free_rectangles",
    "overlay_boxes",
    "format_length",
    "format_time",
    "format_value",
    "series_name_unit",
]

#: printed form of a unit (degrees as the degree sign)
_UNIT_TEXT = {"deg": "°", "deg/s": "°/s", "deg/s²": "°/s²", "1": ""}
#: components of a 3-vector series
_XYZ = "(x, y, z)"
_WHITE, _BLACK = (255, 255, 255), (0, 0, 0)


class OverlayError(ValueError):
    """A colormap or overlay setting is invalid (the message names it)."""


@dataclass(frozen=True)
class LegendEntry:
    """One legend row: ``colours`` (one to three RGB triples in [0, 1]) and the ``text``."""

    colours: tuple[tuple[float, float, float], ...]
    text: str


@dataclass(frozen=True)
class ColourBar:
    """The node-height colour bar: ``cmap`` (matplotlib name), ``limit_m`` (the height [m] at
    both ends, ±) and the ``caption`` lines printed above it."""

    cmap: str
    limit_m: float
    caption: tuple[str, ...] = ("top-node height", "above the top-layer plane")


@dataclass(frozen=True)
class Inset:
    """The inset plot: series ``name`` (printed with its unit), times ``t`` (T,) [s], ``values``
    (T,) and the record index ``upto`` of the frame."""

    name: str
    t: np.ndarray
    values: np.ndarray
    upto: int


@lru_cache(maxsize=8)
def colormap(name: str):
    """The matplotlib colormap ``name`` (an :class:`OverlayError` naming ``height_cmap`` if unknown)."""
    try:
        return matplotlib.colormaps[name]
    except KeyError:
        raise OverlayError(f"height_cmap: unknown matplotlib colormap {name!r}") from None


@lru_cache(maxsize=16)
def _font(size: int) -> ImageFont.FreeTypeFont:
    """DejaVu Sans (shipped with matplotlib; has ×, ±, ², °, µ, θ, ω) at ``size`` px."""
    path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"
    try:
        return ImageFont.truetype(str(path), size)
    except OSError:
        return ImageFont.load_default(size=size)


@lru_cache(maxsize=8)
def _colour_bar_image(cmap: str, height: int, width: int) -> Image.Image:
    """Vertical colour bar image, top = colormap end (positive heights)."""
    colours = (colormap(cmap)(np.linspace(1.0, 0.0, height))[:, :3] * 255).astype(np.uint8)
    return Image.fromarray(np.ascontiguousarray(np.repeat(colours[:, None, :], width, axis=1)))


# --------------------------------------------------------------------------- text


def series_name_unit(
    name: str, *, names: Mapping[str, str] | None = None, units: Mapping[str, str] | None = None
) -> tuple[str, str]:
    """``(readable name, printed unit)`` of series ``name``.

    The name is ``names[name]`` if given, else the quantity part of ``name`` with spaces
    (``omega_norm_rad_s`` → ``omega norm``); the unit is ``units[name]`` if given, else the one
    of the name's SI suffix (:func:`magsail_mj.records.units_of`),
    degrees printed as ``°``, ``""`` for a dimensionless series.
    """
    unit, long_name = units_of(name)
    if units and name in units:
        unit = str(units[name])
    if names and name in names:
        long_name = str(names[name])
    return long_name, _UNIT_TEXT.get(unit, unit)


def format_length(x: float) -> str:
    """``x`` [m] with an SI prefix: ``0 m``, ``12.3 µm``, ``4.56 mm``, ``7.89 m``."""
    if x == 0:
        return "0 m"
    if abs(x) < 1e-3:
        return f"{x * 1e6:.3g} µm"
    if abs(x) < 1:
        return f"{x * 1e3:.3g} mm"
    return f"{x:.3g} m"


def format_time(t_s: float) -> str:
    """``t = 600.0 s``, with minutes from 2 min and hours from 2 h: ``t = 7200.0 s (2.00 h)``;
    below 10 s with four significant digits (``t = 0.0105 s``)."""
    text = f"t = {t_s:.4g} s" if abs(t_s) < 10.0 else f"t = {t_s:.1f} s"
    if abs(t_s) >= 7200.0:
        return text + f" ({t_s / 3600.0:.2f} h)"
    if abs(t_s) >= 120.0:
        return text + f" ({t_s / 60.0:.1f} min)"
    return text


def _digits(x: float, significant: int) -> str:
    """``x`` with ``significant`` digits, positional between 10⁻³ and 10⁶ (``2460``, not ``2.46e+03``)."""
    if x == 0 or not np.isfinite(x) or not 1e-3 <= abs(x) < 1e6:
        return f"{x:.{significant}g}"
    return np.format_float_positional(x, precision=significant, unique=False, fractional=False, trim="-")


def _with_unit(text: str, unit: str) -> str:
    return text + ("" if not unit else unit if unit.startswith("°") else " " + unit)


def _number(x: float, unit: str) -> str:
    if unit == "m" and np.isfinite(x):
        return format_length(float(x))
    return _with_unit(_digits(x, 4), unit)


def format_value(
    name: str,
    value: Any,
    *,
    names: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    labels: Mapping[str, Mapping[str, str]] | None = None,
) -> str:
    """One overlay line for series ``name`` at one record.

    ``name = 12.3 unit`` (readable name and unit: :func:`series_name_unit`); a 3-vector as
    ``name (x, y, z) = [a, b, c] unit``; an enumeration (``labels[name]`` maps the integer value,
    as a string, to its meaning) as ``name: meaning``; a value outside ``labels`` is printed as a
    number.
    """
    readable, unit = series_name_unit(name, names=names, units=units)
    v = np.atleast_1d(np.asarray(value, dtype=float))
    table = labels.get(name) if labels else None
    if table and v.size == 1 and np.isfinite(v[0]) and float(v[0]).is_integer():
        meaning = table.get(str(int(v[0])))
        if meaning is not None:
            return f"{readable}: {meaning}"
    if v.size == 1:
        return f"{readable} = {_number(float(v[0]), unit)}"
    head = f"{readable} {_XYZ}" if v.size == 3 else readable
    if unit == "m" and np.all(np.isfinite(v)):
        return f"{head} = [" + ", ".join(format_length(float(x)) for x in v) + "]"
    return f"{head} = " + _with_unit("[" + ", ".join(_digits(float(x), 3) for x in v) + "]", unit)


# --------------------------------------------------------------------------- drawing


def _rgb255(colour: Sequence[float]) -> tuple[int, int, int]:
    return tuple(int(round(255 * min(max(float(c), 0.0), 1.0))) for c in colour[:3])  # type: ignore[return-value]


def _fit_font(draw: ImageDraw.ImageDraw, text: str, size: int, width: float) -> ImageFont.FreeTypeFont:
    """The largest font, from ``size`` px down to 60 % of it, in which ``text`` fits ``width``."""
    for s in range(size, max(8, int(0.6 * size)) - 1, -1):
        font = _font(s)
        if draw.textlength(text, font=font) <= width:
            return font
    return _font(max(8, int(0.6 * size)))


def _legend_width(draw: ImageDraw.ImageDraw, entries: Sequence[LegendEntry], size: int) -> float:
    """Width [px] of the legend rows at text size ``size`` [px] (swatches and text)."""
    font, sw, gap = _font(size), round(size * 0.8), max(2, size // 4)
    return max(len(e.colours) * (sw + gap) + gap + draw.textlength(e.text, font=font) for e in entries)


def _draw_legend(
    draw: ImageDraw.ImageDraw, entries: Sequence[LegendEntry], *, right: float, top: float, size: int, ink: dict
) -> float:
    """Legend rows right-aligned at ``right`` from ``top`` [px]; returns the bottom [px]."""
    if not entries:
        return top
    font = _font(size)
    sw, gap = round(size * 0.8), max(2, size // 4)
    text_w = max(draw.textlength(e.text, font=font) for e in entries)
    x_text = right - text_w
    y = top
    for e in entries:
        x = x_text - gap - len(e.colours) * (sw + gap) + gap
        for c in e.colours:
            draw.rectangle([x, y + size * 0.15, x + sw, y + size * 0.15 + sw], fill=_rgb255(c), outline=(200, 200, 200))
            x += sw + gap
        draw.text((x_text, y), e.text, font=font, **ink)
        y += size + gap
    return y


@dataclass(frozen=True)
class PanelText:
    """What a panel's overlay says, besides the time and the values of a frame.

    Attributes:
      title: first line, top left (shrunk to fit the width).
      end_line: why the run ended (:func:`magsail_mj.render.ending.end_reason`), printed in
        orange under the values once the run has ended; without it an ended run reads "(run ended)".
      legend: the legend rows, top right.
      identity: the bottom-right line (scenario and config hash).
      exaggeration: out-of-plane factor k; "×k exaggerated" is printed when k != 1.
      label: the panel label (bottom centre) or ``None``.
      colour_bar: the node-height colour bar or ``None``.
      inset: the inset plot or ``None``; ``names``/``units``: its series' name and unit overrides.
    """

    title: str
    end_line: str = ""
    legend: Sequence[LegendEntry] = ()
    identity: str = ""
    exaggeration: float = 1.0
    label: str | None = None
    colour_bar: ColourBar | None = None
    inset: Inset | None = None
    names: Mapping[str, str] | None = None
    units: Mapping[str, str] | None = None


@dataclass(frozen=True)
class _BarGeometry:
    """Where the colour bar goes: bar at ``x0, y0`` (``bar_w`` x ``bar_h`` px), caption fonts."""

    x0: int
    y0: int
    bar_w: int
    bar_h: int
    caption: tuple[ImageFont.FreeTypeFont, ...]


def _bar_labels(bar: ColourBar) -> list[tuple[float, str]]:
    """``(fraction down the bar, text)`` of the colour bar's three values."""
    return [
        (frac, ("+" if value > 0 else "−" if value < 0 else "") + format_length(abs(value)))
        for frac, value in ((0.0, bar.limit_m), (0.5, 0.0), (1.0, -bar.limit_m))
    ]


def _bar_geometry(
    draw: ImageDraw.ImageDraw, bar: ColourBar, *, w: int, h: int, top: float, bottom: float, size: int, pad: int
) -> _BarGeometry | None:
    """The colour bar's place between ``top`` and ``bottom`` [px] at the right edge (``None``: no room)."""
    caption = tuple(_fit_font(draw, line, size, w / 3) for line in bar.caption)
    y0 = max(int(top) + len(caption) * size + pad, (h - h // 3) // 2)
    bar_h = min(h // 3, int(bottom) - y0 - size // 2)
    if bar_h < 3 * size:
        return None
    bar_w = max(6, size // 2)
    return _BarGeometry(w - pad - bar_w, y0, bar_w, bar_h, caption)


def _draw_colour_bar(
    img: Image.Image,
    draw: ImageDraw.ImageDraw,
    bar: ColourBar,
    geometry: _BarGeometry,
    *,
    size: int,
    pad: int,
    ink: dict,
) -> None:
    """The colour bar at ``geometry`` (:func:`_bar_geometry`), caption above it."""
    w = img.width
    font = _font(size)
    x0, y0, bar_h = geometry.x0, geometry.y0, geometry.bar_h
    img.paste(_colour_bar_image(bar.cmap, bar_h, geometry.bar_w), (x0, y0))
    for frac, text in _bar_labels(bar):
        tw = draw.textlength(text, font=font)
        draw.text((x0 - pad - tw, y0 + frac * bar_h - size / 2), text, font=font, **ink)
    n = len(geometry.caption)
    for k, (line, line_font) in enumerate(zip(bar.caption, geometry.caption)):
        tw = draw.textlength(line, font=line_font)
        draw.text((w - pad - tw, y0 - (n - k) * size - pad), line, font=line_font, **ink)


def _draw_inset(
    draw: ImageDraw.ImageDraw,
    inset: Inset,
    *,
    box: tuple[float, float, float, float],
    font: ImageFont.FreeTypeFont,
    ink: dict,
    units: Mapping[str, str] | None = None,
    names: Mapping[str, str] | None = None,
) -> None:
    """A small plot of ``inset.values`` against ``inset.t`` up to record ``inset.upto`` inside
    ``box`` (x0, y0, x1, y1) [px].

    The axes span the whole run (so the curve grows from left to right); the current value is a
    dot; a line above the box gives the series name, its range with its unit and the time span.
    """
    x0, y0, x1, y1 = box
    t, values, upto = inset.t, inset.values, inset.upto
    draw.rectangle(box, fill=_BLACK, outline=(160, 160, 160))
    finite = values[np.isfinite(values)]
    if finite.size == 0 or t[-1] <= t[0]:
        return
    lo, hi = float(finite.min()), float(finite.max())
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    inner = 4
    xs = x0 + inner + (t[: upto + 1] - t[0]) / (t[-1] - t[0]) * (x1 - x0 - 2 * inner)
    ys = y1 - inner - (values[: upto + 1] - lo) / (hi - lo) * (y1 - y0 - 2 * inner)
    ok = np.isfinite(ys)
    points = list(zip(xs[ok].tolist(), ys[ok].tolist()))
    if len(points) > 1:
        draw.line(points, fill=(255, 200, 60), width=2)
    if points:
        px, py = points[-1]
        draw.ellipse([px - 3, py - 3, px + 3, py + 3], fill=(255, 80, 60))
    header = _inset_header(inset, names=names, units=units)
    size = int(getattr(font, "size", 10))
    header_font = _fit_font(draw, header, size, 1.5 * (x1 - x0))
    draw.text((x0, y0 - int(getattr(header_font, "size", size)) - 3), header, font=header_font, **ink)


def _inset_header(inset: Inset, *, names: Mapping[str, str] | None, units: Mapping[str, str] | None) -> str:
    """The line above the inset: series name, its range with its unit, the time span."""
    t, values = inset.t, inset.values
    finite = values[np.isfinite(values)]
    if finite.size == 0 or t[-1] <= t[0]:
        return ""
    lo, hi = float(finite.min()), float(finite.max())
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    readable, unit = series_name_unit(inset.name, names=names, units=units)
    return f"{readable}: {_number(lo, unit)} … {_number(hi, unit)} over t = {t[0]:.4g} … {t[-1]:.4g} s"


#: a box on the image: (x0, y0, x1, y1) [px], y downwards
Box = tuple[float, float, float, float]
#: colour of the line that says why a run ended
_END_RGB = (255, 150, 110)


@dataclass(frozen=True)
class _Layout:
    """Where each part of the overlay goes (computed once by :func:`_layout`, drawn by
    :func:`draw_overlay`, reserved by :func:`overlay_boxes`)."""

    size: int
    pad: int
    big: ImageFont.FreeTypeFont
    lines_top: int
    lines: tuple[str, ...]
    end_font: ImageFont.FreeTypeFont | None
    legend_size: int
    legend_top: float
    legend_bottom: float
    bottom_row: int
    identity_font: ImageFont.FreeTypeFont | None
    bar: _BarGeometry | None
    inset_box: Box | None
    label_font: ImageFont.FreeTypeFont | None
    boxes: tuple[Box, ...]


def _layout(
    draw: ImageDraw.ImageDraw,
    w: int,
    h: int,
    *,
    title: str,
    lines: Sequence[str],
    end_line: str,
    legend: Sequence[LegendEntry],
    identity: str,
    exaggeration: float,
    label: str | None,
    colour_bar: ColourBar | None,
    inset_header: str | None,
) -> _Layout:
    """The overlay's layout on a ``w`` x ``h`` panel and the boxes its parts cover."""
    size = max(10, round(h / 30))
    small = _font(size)
    pad = size // 2
    big = _fit_font(draw, title, round(size * 1.25), w - 2 * pad)
    boxes: list[Box] = [(pad, pad, pad + draw.textlength(title, font=big), pad + round(size * 1.25))]
    top = pad + round(size * 1.25) + pad
    y = top
    widths = [draw.textlength(line, font=small) for line in lines]
    y += len(lines) * (size + pad // 2)
    end_font = None
    if end_line:
        end_font = _fit_font(draw, end_line, size, w - 2 * pad)
        widths.append(draw.textlength(end_line, font=end_font))
        y += size + pad // 2
    if widths:
        boxes.append((pad, top, pad + max(widths), y))
    legend_size, legend_top, legend_bottom = size, float(top), float(top)
    if legend:  # beside the lines, in a smaller size if needed (down to 70 %), else below them
        room = w - 3 * pad - max(widths, default=0.0)
        fits = [s for s in range(size, max(8, round(0.7 * size)) - 1, -1) if _legend_width(draw, legend, s) <= room]
        legend_size, legend_top = (fits[0], float(top)) if fits else (size, float(y))
        gap = max(2, legend_size // 4)
        legend_bottom = legend_top + len(legend) * (legend_size + gap)
        sw, font = round(legend_size * 0.8), _font(legend_size)
        extent = max(draw.textlength(e.text, font=font) for e in legend) + max(len(e.colours) for e in legend) * (
            sw + gap
        )
        boxes.append((w - pad - extent, legend_top, w - pad, legend_bottom))
    bottom_row = h - pad - size
    identity_font = None
    if identity:
        identity_font = _fit_font(draw, identity, size, w / 2 - 2 * pad)
        boxes.append((w - pad - draw.textlength(identity, font=identity_font), bottom_row, w - pad, h - pad))
    bar = None
    if colour_bar is not None:
        bar = _bar_geometry(draw, colour_bar, w=w, h=h, top=legend_bottom, bottom=bottom_row - pad, size=size, pad=pad)
        if bar is not None:
            n = len(bar.caption)
            label_w = max(draw.textlength(text, font=small) for _, text in _bar_labels(colour_bar))
            caption_w = max(draw.textlength(line, font=f) for line, f in zip(colour_bar.caption, bar.caption))
            x_left = min(bar.x0 - pad - label_w, w - pad - caption_w)
            boxes.append((x_left, bar.y0 - n * size - pad, w - pad, bar.y0 + bar.bar_h + size / 2))
    if exaggeration != 1.0:
        text = _exaggeration_text(exaggeration)
        boxes.append((pad, bottom_row, pad + draw.textlength(text, font=small), h - pad))
    inset_box = None
    if inset_header is not None:
        bottom = bottom_row - pad
        inset_box = (pad, bottom - h // 4, pad + w // 3, bottom)
        header_w = 0.0
        header_h = 0
        if inset_header:
            header_font = _fit_font(draw, inset_header, size, 1.5 * (w // 3))
            header_w, header_h = draw.textlength(inset_header, font=header_font), int(header_font.size) + 3
        boxes.append((pad, inset_box[1] - header_h, pad + max(w // 3, header_w), bottom))
    label_font = None
    if label:
        label_font = _fit_font(draw, label, round(size * 1.25), w / 2)
        tw = draw.textlength(label, font=label_font)
        y_label = bottom_row - round(size * 1.25) - pad
        boxes.append(((w - tw) / 2, y_label, (w + tw) / 2, y_label + round(size * 1.25) + pad))
    return _Layout(
        size=size,
        pad=pad,
        big=big,
        lines_top=top,
        lines=tuple(lines),
        end_font=end_font,
        legend_size=legend_size,
        legend_top=legend_top,
        legend_bottom=legend_bottom,
        bottom_row=bottom_row,
        identity_font=identity_font,
        bar=bar,
        inset_box=inset_box,
        label_font=label_font,
        boxes=tuple(boxes),
    )


def _exaggeration_text(k: float) -> str:
    return f"×{k:g} exaggerated (out-of-plane motion)"


def overlay_boxes(width: int, height: int, text: PanelText, *, lines: Sequence[str], ended: bool) -> list[Box]:
    """The boxes (x0, y0, x1, y1) [px, y downwards] that the overlay of :func:`draw_overlay`
    covers on a ``width`` x ``height`` panel with ``text`` (``lines``: the time line and the value
    lines as drawn, the longest of the run for a whole video; ``ended``: the end line is shown)."""
    draw = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    return list(_text_layout(draw, int(width), int(height), text, lines=lines, ended=ended).boxes)


def _text_layout(
    draw: ImageDraw.ImageDraw, w: int, h: int, text: PanelText, *, lines: Sequence[str], ended: bool
) -> _Layout:
    """:func:`_layout` of ``text`` with ``lines`` (the end line only once the run has ended)."""
    header = _inset_header(text.inset, names=text.names, units=text.units) if text.inset is not None else None
    return _layout(
        draw,
        w,
        h,
        title=text.title,
        lines=lines,
        end_line=text.end_line if ended else "",
        legend=text.legend,
        identity=text.identity,
        exaggeration=text.exaggeration,
        label=text.label,
        colour_bar=text.colour_bar,
        inset_header=header,
    )


def free_rectangles(width: int, height: int, boxes: Sequence[Box], *, margin: float) -> list[Box]:
    """The largest rectangles of a ``width`` x ``height`` panel that keep ``margin`` [px] from
    its edges and from every box (each not inside another; none when the boxes leave no room).

    Candidates take their edges from the panel's and the boxes' edges; those at least an eighth
    of the panel wide and high and clear of every box are kept."""
    grown = [(x0 - margin, y0 - margin, x1 + margin, y1 + margin) for x0, y0, x1, y1 in boxes]
    lefts = sorted({margin, *(b[2] for b in grown if margin < b[2] < width - margin)})
    rights = sorted({width - margin, *(b[0] for b in grown if margin < b[0] < width - margin)})
    tops = sorted({margin, *(b[3] for b in grown if margin < b[3] < height - margin)})
    bottoms = sorted({height - margin, *(b[1] for b in grown if margin < b[1] < height - margin)})
    found: list[Box] = []
    for x0 in lefts:
        for x1 in rights:
            if x1 - x0 < width / 8:
                continue
            for y0 in tops:
                for y1 in bottoms:
                    if y1 - y0 < height / 8:
                        continue
                    if all(b[2] <= x0 or b[0] >= x1 or b[3] <= y0 or b[1] >= y1 for b in grown):
                        found.append((x0, y0, x1, y1))
    return [
        r
        for r in found
        if not any(o != r and o[0] <= r[0] and o[1] <= r[1] and o[2] >= r[2] and o[3] >= r[3] for o in found)
    ]


def draw_overlay(
    image: np.ndarray, text: PanelText, *, time_s: float, ended: bool, values: Sequence[str]
) -> np.ndarray:
    """The frame ``image`` (H, W, 3) uint8 with its overlay drawn (layout: module docstring).

    Args:
      text: the title, legend, end line, … of the panel (:class:`PanelText`).
      time_s: the frame's record time [s]; ``ended``: the run ended before the frame time.
      values: overlay lines (:func:`format_value`).
    """
    h, w = image.shape[:2]
    img = Image.fromarray(image)
    draw = ImageDraw.Draw(img)
    time_line = format_time(time_s) + ("  (run ended)" if ended and not text.end_line else "")
    lines = [time_line, *values]
    lay = _text_layout(draw, w, h, text, lines=lines, ended=ended)
    title, end_line, legend, identity = text.title, text.end_line, text.legend, text.identity
    exaggeration, colour_bar, inset = text.exaggeration, text.colour_bar, text.inset
    names, units, label = text.names, text.units, text.label
    size, pad = lay.size, lay.pad
    small = _font(size)
    ink = {"fill": _WHITE, "stroke_width": max(1, size // 9), "stroke_fill": _BLACK}
    draw.text((pad, pad), title, font=lay.big, **ink)
    y = lay.lines_top
    for line in lines:
        draw.text((pad, y), line, font=small, **ink)
        y += size + pad // 2
    if lay.end_font is not None:
        draw.text((pad, y), end_line, font=lay.end_font, **{**ink, "fill": _END_RGB})
    if legend:
        _draw_legend(draw, legend, right=w - pad, top=lay.legend_top, size=lay.legend_size, ink=ink)
    bottom_row = lay.bottom_row
    if identity and lay.identity_font is not None:
        font = lay.identity_font
        draw.text(
            (w - pad - draw.textlength(identity, font=font), bottom_row),
            identity,
            font=font,
            fill=(200, 200, 200),
            stroke_width=ink["stroke_width"],
            stroke_fill=_BLACK,
        )
    if colour_bar is not None and lay.bar is not None:
        _draw_colour_bar(img, draw, colour_bar, lay.bar, size=size, pad=pad, ink=ink)
    if exaggeration != 1.0:
        draw.text((pad, bottom_row), _exaggeration_text(exaggeration), font=small, **ink)
    if inset is not None and lay.inset_box is not None:
        _draw_inset(draw, inset, box=lay.inset_box, font=small, ink=ink, names=names, units=units)
    if label and lay.label_font is not None:
        tw = draw.textlength(label, font=lay.label_font)
        draw.text(((w - tw) / 2, bottom_row - round(size * 1.25) - pad), label, font=lay.label_font, **ink)
    return np.asarray(img)
