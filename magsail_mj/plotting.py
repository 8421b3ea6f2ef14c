"""Shared figure helpers: one :func:`save_figure` for every plot module and script.

Figures are written as PNG through :func:`magsail_mj.io.atomic_path` (a temporary file in the
target folder moved into place), so a reader never sees half a picture and a crash keeps the
previous file. :func:`new_figure` builds a :class:`matplotlib.figure.Figure` without pyplot's
global figure list, so a plot module needs no backend selection (``matplotlib.use("Agg")``) and
leaves an interactive session's backend alone.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from magsail_mj.io import atomic_path

__all__ = ["save_figure", "new_figure", "PNG_DPI"]

PNG_DPI = 120
"""Resolution of every saved figure [dots per inch]."""


def save_figure(fig: Figure, path: Path) -> Path:
    """Save ``fig`` atomically as PNG at ``path`` (``PNG_DPI``, tight bounding box), close it, return ``path``.

    The file is written under a temporary name in ``path``'s folder and renamed into place.
    Closing releases a pyplot-managed figure (a figure from :func:`new_figure` is not in pyplot's
    list, and closing it is a no-op).
    """
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=PNG_DPI, bbox_inches="tight", format="png")
    plt.close(fig)
    return path


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] = (7.0, 4.0),
               **subplot_kw: Any) -> tuple[Figure, Any]:
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
