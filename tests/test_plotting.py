"""The shared figure helpers: atomic PNG writing and pyplot-free figures."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from PIL import Image

from magsail_mj.plotting import PNG_DPI, figure_problems, mark_run_end, new_figure, save_figure


def test_save_figure_writes_png_of_figure_size_and_leaves_no_temporary(tmp_path):
    fig, ax = new_figure(figsize=(4.0, 3.0))
    ax.plot([0.0, 1.0], [0.0, 1.0])
    out = save_figure(fig, tmp_path / "line.png")
    assert out == tmp_path / "line.png"
    assert [p.name for p in tmp_path.iterdir()] == ["line.png"]
    with Image.open(out) as img:
        assert img.format == "PNG"
        w, h = img.size
    # tight bounding box trims margins: at most the nominal size, at least half of it
    assert PNG_DPI * 4.0 / 2 <= w <= PNG_DPI * 4.0 + 1
    assert PNG_DPI * 3.0 / 2 <= h <= PNG_DPI * 3.0 + 1


def test_save_figure_closes_a_pyplot_figure(tmp_path):
    before = set(plt.get_fignums())
    fig = plt.figure()
    assert fig.number in plt.get_fignums()
    save_figure(fig, tmp_path / "f.png")
    assert set(plt.get_fignums()) == before


def test_new_figure_is_outside_pyplot_and_shapes_axes():
    before = set(plt.get_fignums())
    fig, axs = new_figure(3, 2, sharex=True)
    assert np.shape(axs) == (3, 2)
    assert set(plt.get_fignums()) == before
    with pytest.raises(ValueError, match="nrows"):
        new_figure(0)
    with pytest.raises(ValueError, match="ncols"):
        new_figure(1, 0)


def test_mark_run_end_puts_the_cause_at_the_curve_end():
    """A curve that stops early ends in a marker at its last finite point, with the cause beside
    it; the figure stays readable (no unlabelled colours, no legend gaps)."""
    fig, ax = new_figure()
    t = np.linspace(0.0, 646.0, 50)
    y = np.sin(t / 100.0)
    y[-3:] = np.nan  # the last finite point is the end
    (curve,) = ax.plot(t, y, label="central")
    ax.set(xlabel="t [s]", ylabel="surface SD [m]")
    reason = "structure failed at 646 s: strut 1330 strain 0.501 > 0.5"
    mark_run_end(ax, t, y, reason, colour=curve.get_color())
    marker = ax.lines[-1]
    assert marker.get_marker() == "X"
    assert (marker.get_xdata()[0], marker.get_ydata()[0]) == (t[-4], y[-4])
    assert [text.get_text() for text in ax.texts] == [reason]
    assert figure_problems(fig) == []
