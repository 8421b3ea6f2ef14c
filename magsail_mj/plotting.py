"""Shared figure helpers: one :func:`save_figure` for every plot module and script.

Figures are written as PNG through :func:`magsail_mj.io.atomic_path` (a temporary file in the
target folder moved into place), so a reader never sees half a picture and a crash keeps the
previous file. :func:`new_figure` builds a :class:`matplotlib.figure.Figure` without pyplot's
global figure list, so a plot module needs no backend selection (``matplotlib.use("Agg")``) and
leaves an interactive session's backend alone.

Readability rules (:func:`figure_problems`), checked by :func:`save_figure` when the environment
variable ``MAGSAIL_CHECK_FIGURES`` is ``1`` (the tests set it): every axis with data has a label
(an axis sharing a labelled axis may leave it to that one; a categorical axis is named by its
ticks), every label carries a unit in square brackets or a short one in parentheses at its end
(``[N m]``, ``[°/s]``, ``(km)``; ``[–]`` for a pure number), except the dimensionless labels of
:data:`DIMENSIONLESS_LABELS`; a panel with several labelled artists has them in a legend (its own,
another panel's or the figure's); several unlabelled lines of different colours in one panel are
an error (a reader cannot tell them apart).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.category import UnitData
from matplotlib.colors import to_hex
from matplotlib.figure import Figure

from magsail_mj.io import atomic_path

__all__ = [
    "mark_run_end",
    "save_figure",
    "new_figure",
    "figure_problems",
    "FigureCheckError",
    "DIMENSIONLESS_LABELS",
    "CHECK_ENV",
    "PNG_DPI",
]

PNG_DPI = 120
"""Resolution of every saved figure [dots per inch]."""

CHECK_ENV = "MAGSAIL_CHECK_FIGURES"
"""Environment variable: ``1`` makes :func:`save_figure` refuse a figure with :func:`figure_problems`."""

DIMENSIONLESS_LABELS = frozenset(
    {
        "max strut strain",  # ΔL/L of the most strained strut
        "q̂_n",  # modal amplitudes normalised by their largest value
        "cycle k",  # cycle count
        "|ẑ_B · V̂| (projected area fraction)",  # cosine between sail normal and flight direction
        "signed active rods",  # rod count times polarity
        "rods on",  # rod count
        "runs",  # a histogram's run count (sweep report)
        "F(x) over all runs",  # an empirical distribution function (sweep report)
    }
)
"""Axis labels of dimensionless quantities (ratios, counts, normalised amplitudes), accepted
without a unit."""

#: a unit: a bracketed group anywhere, or a short parenthesised group at the end of the label
_UNIT = re.compile(r"\[[^\]]+\]|\([^()]{1,12}\)\s*$")


class FigureCheckError(ValueError):
    """A figure breaks a readability rule (:func:`figure_problems`); the message lists each problem."""


def _axis_problem(ax: Axes, axis: Axis, which: str) -> str | None:
    """The problem of one axis (``which`` = ``"x"``, ``"y"`` or ``"z"``) of ``ax``, or ``None``."""
    if isinstance(axis.units, UnitData):  # categorical: the tick labels name the categories
        return None
    label = axis.get_label().get_text().strip()
    if not label:
        shared = getattr(ax, f"get_shared_{which}_axes", None)
        siblings = shared().get_siblings(ax) if shared is not None else [ax]
        if any(getattr(s, f"get_{which}label")().strip() for s in siblings if s is not ax):
            return None
        return f"{which} axis has no label"
    if label in DIMENSIONLESS_LABELS or _UNIT.search(label):
        return None
    return f"{which} label {label!r} has no unit in [brackets] or (parentheses)"


def _has_data(ax: Axes) -> bool:
    return bool(ax.lines or ax.collections or ax.patches or ax.images)


def _legend_texts(fig: Figure) -> set[str]:
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return {t.get_text() for leg in legends for t in leg.get_texts()}


def _flatten(items: Any) -> list[Any]:
    """The artists of a container (nested tuples: an error bar's line, caps and bars)."""
    if isinstance(items, (tuple, list)):
        return [a for item in items for a in _flatten(item)]
    return [] if items is None else [items]


def _legend_problems(ax: Axes, shown: set[str]) -> list[str]:
    """Several labelled artists, some missing from every legend; unlabelled data lines of several colours."""
    problems = []
    _, labels = ax.get_legend_handles_labels()
    missing = [lab for lab in labels if lab not in shown]
    if len(labels) > 1 and missing:
        problems.append(f"labelled artists without a legend: {missing}")
    named = {id(a) for c in ax.containers if not c.get_label().startswith("_") for a in _flatten(c)}
    unlabelled = {
        to_hex(line.get_color())
        for line in ax.lines
        if line.get_label().startswith("_") and line.get_transform() is ax.transData and id(line) not in named
    }
    if len(unlabelled) > 1:
        problems.append(f"{len(unlabelled)} unlabelled line colours {sorted(unlabelled)} (no legend can name them)")
    return problems


def figure_problems(fig: Figure) -> list[str]:
    """What makes ``fig`` unreadable without the docs (module docstring); ``[]`` when nothing.

    Each problem names its panel (number and title) and axis."""
    problems = []
    shown = _legend_texts(fig)
    for k, ax in enumerate(fig.axes):
        if not ax.get_visible() or not ax.axison:
            continue
        where = f"panel {k}" + (f" ({ax.get_title()!r})" if ax.get_title() else "")
        bar = getattr(ax, "_colorbar", None)
        if bar is not None:
            axes = [(ax.yaxis, "y")] if bar.orientation == "vertical" else [(ax.xaxis, "x")]
        elif _has_data(ax):
            axes = [(ax.xaxis, "x"), (ax.yaxis, "y")] + ([(ax.zaxis, "z")] if hasattr(ax, "zaxis") else [])
        else:
            continue
        problems += [f"{where}: {p}" for axis, which in axes if (p := _axis_problem(ax, axis, which))]
        problems += [f"{where}: {p}" for p in _legend_problems(ax, shown)]
    return problems


def save_figure(fig: Figure, path: Path) -> Path:
    """Save ``fig`` atomically as PNG at ``path`` (``PNG_DPI``, tight bounding box), close it, return ``path``.

    The file is written under a temporary name in ``path``'s folder and renamed into place.
    Closing releases a pyplot-managed figure (a figure from :func:`new_figure` is not in pyplot's
    list, and closing it is a no-op).

    Raises:
      FigureCheckError: ``MAGSAIL_CHECK_FIGURES=1`` and the figure breaks a readability rule
        (:func:`figure_problems`); nothing is written.
    """
    path = Path(path)
    if os.environ.get(CHECK_ENV, "") == "1" and (problems := figure_problems(fig)):
        plt.close(fig)
        raise FigureCheckError(f"{path.name}: " + "; ".join(problems))
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=PNG_DPI, bbox_inches="tight", format="png")
    plt.close(fig)
    return path


def mark_run_end(
    ax: Axes,
    t: Any,
    y: Any,
    text: str,
    *,
    colour: Any = None,
    label: str | None = None,
    annotate: bool = True,
) -> None:
    """Mark where a curve stops because its run ended early: an ✕ at the curve's last finite
    point (``t``, ``y``: the curve's data) in ``colour`` (the curve's), with ``label`` as its
    legend entry when given, and, with ``annotate``, ``text`` (why the run ended:
    :func:`magsail_mj.render.ending.end_reason`) beside it.

    Nothing is drawn when the curve has no finite point."""
    t = np.asarray(t, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float).reshape(-1)
    ok = np.flatnonzero(np.isfinite(t) & np.isfinite(y))
    if not ok.size:
        return
    x_end, y_end = float(t[ok[-1]]), float(y[ok[-1]])
    ax.plot(
        [x_end],
        [y_end],
        "X",
        color=colour,
        markersize=9,
        markeredgecolor="black",
        label=label if label is not None else "_run_end",
        zorder=5,
    )
    if annotate:
        ax.annotate(
            text,
            (x_end, y_end),
            xytext=(8, 8),
            textcoords="offset points",
            fontsize="small",
            color="black",
            bbox={"boxstyle": "round,pad=0.25", "facecolor": "#fff3e0", "edgecolor": "#d95f02"},
            zorder=6,
        )


def new_figure(
    nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] = (7.0, 4.0), **subplot_kw: Any
) -> tuple[Figure, Any]:
    """A figure and its axes (as ``plt.subplots``) outside pyplot's state; ``figsize`` in inches.

    ``subplot_kw`` goes to :meth:`matplotlib.figure.Figure.subplots` (``sharex``, ``squeeze``,
    ``subplot_kw``, ...). Returns ``(fig, ax)`` for one panel, ``(fig, axes array)`` otherwise.
    """
    if nrows < 1:
        raise ValueError(f"nrows must be ≥ 1, got {nrows}")
    if ncols < 1:
        raise ValueError(f"ncols must be ≥ 1, got {ncols}")
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **subplot_kw)
