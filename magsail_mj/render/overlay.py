"""The 2-D overlay of a video frame (PIL): text, legend, colour bar, inset plot, run identity.

Layout of one panel (``h`` px high, text size ``s = max(10, round(h / 30))`` px):

- top left: the title (1.25 s), the time ``t = 600.0 s (10.0 min)``, then one line per overlay
  series, ``name = value unit`` (:func:`format_value`);
- top right, below the title row: the legend, one row per colour shown (:class:`LegendEntry`:
  one to three swatches and a text);
- right, below the legend: the colour bar of the node heights, its caption and its values with
  units;
- lower left: the inset plot (one series' history up to the frame's time), and under it
  "×k exaggerated" when the out-of-plane motion is magnified;
- bottom centre: the panel label (side-by-side comparisons);
- bottom right: the run's identity, ``scenario <name> · config <first 12 hex digits of the
  config hash>``.

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
    "colormap",
    "draw_overlay",
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


def _draw_colour_bar(
    img: Image.Image,
    draw: ImageDraw.ImageDraw,
    bar: ColourBar,
    *,
    top: float,
    bottom: float,
    size: int,
    pad: int,
    ink: dict,
) -> None:
    """The colour bar between ``top`` and ``bottom`` [px] at the right edge, caption above it."""
    h, w = img.height, img.width
    font = _font(size)
    caption = [_fit_font(draw, line, size, w / 3) for line in bar.caption]
    y0 = max(int(top) + len(caption) * size + pad, (h - h // 3) // 2)
    bar_h = min(h // 3, int(bottom) - y0 - size // 2)
    if bar_h < 3 * size:
        return
    bar_w = max(6, size // 2)
    x0 = w - pad - bar_w
    img.paste(_colour_bar_image(bar.cmap, bar_h, bar_w), (x0, y0))
    for frac, value in ((0.0, bar.limit_m), (0.5, 0.0), (1.0, -bar.limit_m)):
        text = ("+" if value > 0 else "−" if value < 0 else "") + format_length(abs(value))
        tw = draw.textlength(text, font=font)
        draw.text((x0 - pad - tw, y0 + frac * bar_h - size / 2), text, font=font, **ink)
    for k, (line, line_font) in enumerate(zip(bar.caption, caption)):
        tw = draw.textlength(line, font=line_font)
        draw.text((w - pad - tw, y0 - (len(caption) - k) * size - pad), line, font=line_font, **ink)


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
    readable, unit = series_name_unit(inset.name, names=names, units=units)
    header = f"{readable}: {_number(lo, unit)} … {_number(hi, unit)} over t = {t[0]:.4g} … {t[-1]:.4g} s"
    size = int(getattr(font, "size", 10))
    header_font = _fit_font(draw, header, size, 1.5 * (x1 - x0))
    draw.text((x0, y0 - int(getattr(header_font, "size", size)) - 3), header, font=header_font, **ink)


def draw_overlay(
    image: np.ndarray,
    *,
    title: str,
    time_s: float,
    ended: bool,
    values: Sequence[str],
    legend: Sequence[LegendEntry] = (),
    identity: str = "",
    exaggeration: float = 1.0,
    label: str | None = None,
    colour_bar: ColourBar | None = None,
    inset: Inset | None = None,
    names: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
) -> np.ndarray:
    """The frame ``image`` (H, W, 3) uint8 with its overlay drawn (layout: module docstring).

    Args:
      title: first line, top left (shrunk to fit the width).
      time_s: the frame's record time [s]; ``ended``: the run ended before the frame time.
      values: overlay lines (:func:`format_value`).
      legend: the legend rows, top right.
      identity: the bottom-right line (scenario and config hash).
      exaggeration: out-of-plane factor k; "×k exaggerated" is printed when k != 1.
      label: the panel label (bottom centre) or ``None``.
      colour_bar: the node-height colour bar or ``None``.
      inset: the inset plot or ``None``; ``names``/``units``: its series' name and unit overrides.
    """
    h, w = image.shape[:2]
    size = max(10, round(h / 30))
    small = _font(size)
    img = Image.fromarray(image)
    draw = ImageDraw.Draw(img)
    ink = {"fill": _WHITE, "stroke_width": max(1, size // 9), "stroke_fill": _BLACK}
    pad = size // 2
    big = _fit_font(draw, title, round(size * 1.25), w - 2 * pad)
    draw.text((pad, pad), title, font=big, **ink)
    y = top = pad + round(size * 1.25) + pad
    lines = [format_time(time_s) + ("  (run ended)" if ended else ""), *values]
    for line in lines:
        draw.text((pad, y), line, font=small, **ink)
        y += size + pad // 2
    legend_bottom = top
    if legend:  # beside the lines, in a smaller size if needed (down to 70 %), else below them
        room = w - 3 * pad - max(draw.textlength(line, font=small) for line in lines)
        fits = [s for s in range(size, max(8, round(0.7 * size)) - 1, -1) if _legend_width(draw, legend, s) <= room]
        legend_size, legend_top = (fits[0], top) if fits else (size, y)
        legend_bottom = _draw_legend(draw, legend, right=w - pad, top=legend_top, size=legend_size, ink=ink)
    bottom_row = h - pad - size
    if identity:
        font = _fit_font(draw, identity, size, w / 2 - 2 * pad)
        draw.text(
            (w - pad - draw.textlength(identity, font=font), bottom_row),
            identity,
            font=font,
            fill=(200, 200, 200),
            stroke_width=ink["stroke_width"],
            stroke_fill=_BLACK,
        )
    if colour_bar is not None:
        _draw_colour_bar(img, draw, colour_bar, top=legend_bottom, bottom=bottom_row - pad, size=size, pad=pad, ink=ink)
    if exaggeration != 1.0:
        draw.text((pad, bottom_row), f"×{exaggeration:g} exaggerated (out-of-plane motion)", font=small, **ink)
    if inset is not None:
        bottom = bottom_row - pad
        _draw_inset(
            draw, inset, box=(pad, bottom - h // 4, pad + w // 3, bottom), font=small, ink=ink, names=names, units=units
        )
    if label:
        font = _fit_font(draw, label, round(size * 1.25), w / 2)
        tw = draw.textlength(label, font=font)
        draw.text(((w - tw) / 2, bottom_row - round(size * 1.25) - pad), label, font=font, **ink)
    return np.asarray(img)
