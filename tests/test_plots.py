"""Every PNG figure can be read without the docs: axis labels with units, a legend for every
labelled line, no unlabelled lines of several colours (:func:`magsail_mj.plotting.figure_problems`).

The rules are tested on small figures (each rule is broken once and caught); then short runs write
their figures with the check switched on (``MAGSAIL_CHECK_FIGURES=1``:
:func:`magsail_mj.plotting.save_figure` refuses a figure that breaks a rule, and the run fails
naming the figure and the problem): here the CNUSAIL branches, and every scenario kind of every
concept in ``tests/test_render.py`` (``test_every_scenario_kind_renders_its_video``).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.config import load_config
from magsail_mj.plotting import CHECK_ENV, FigureCheckError, figure_problems, new_figure, save_figure
from magsail_mj.run import run_scenario

REPO = Path(__file__).resolve().parents[1]
CONCEPTS = REPO / "magsail_mj" / "concepts"


# --------------------------------------------------------------------------- the rules


def _line_figure(**labels: str):
    fig, ax = new_figure()
    ax.plot([0.0, 1.0], [0.0, 1.0], label="a")
    ax.set(**labels)
    return fig, ax


def test_a_readable_figure_has_no_problem():
    fig, axes = new_figure(2, 1, sharex=True)
    for ax in axes:
        ax.plot([0, 1], [0, 1], label="measured")
        ax.plot([0, 1], [1, 0], label="model")
        ax.axhline(0.5, color="r")  # a reference line needs no label
        ax.set_ylabel("torque [N m]")
    axes[0].legend()  # the second panel repeats the same labels
    axes[1].set_xlabel("time (min)")  # a short unit in parentheses at the end
    assert figure_problems(fig) == []


@pytest.mark.parametrize(
    "labels, problem",
    [
        ({"ylabel": "y [m]"}, "x axis has no label"),
        ({"xlabel": "t [s]"}, "y axis has no label"),
        ({"xlabel": "time", "ylabel": "y [m]"}, "x label 'time' has no unit"),
        ({"xlabel": "t [s]", "ylabel": "yaw (unwrapped, about z)"}, "has no unit"),
    ],
)
def test_an_axis_without_label_or_unit_is_a_problem(labels, problem):
    fig, ax = _line_figure(**labels)
    ax.legend()
    found = figure_problems(fig)
    assert len(found) == 1 and problem in found[0], found


def test_dimensionless_labels_are_listed_and_pure_numbers_say_so():
    fig, ax = _line_figure(xlabel="cycle k", ylabel="ratio [–]")
    ax.legend()
    assert figure_problems(fig) == []
    fig, ax = _line_figure(xlabel="cycle count", ylabel="ratio [–]")
    ax.legend()
    assert "cycle count" in " ".join(figure_problems(fig))


def test_labelled_lines_need_a_legend_and_colours_need_labels():
    fig, ax = _line_figure(xlabel="t [s]", ylabel="y [m]")
    ax.plot([0, 1], [1, 0], label="b")
    assert any("without a legend: ['a', 'b']" in p for p in figure_problems(fig))
    fig, ax = new_figure()
    ax.plot(np.arange(4), np.ones((4, 3)))  # three colours, no labels
    ax.set(xlabel="t [s]", ylabel="ω [rad/s]")
    assert any("3 unlabelled line colours" in p for p in figure_problems(fig))


def test_shared_twin_categorical_and_colour_bar_axes():
    fig, axes = new_figure(1, 2, sharey=True)
    for ax in axes:
        ax.plot([0, 1], [0, 1])
        ax.set_xlabel("t [s]")
    axes[0].set_ylabel("y [m]")  # the shared y axis of the second panel
    twin = axes[1].twinx()
    twin.plot([0, 1], [2, 3], "k")
    twin.set_ylabel("z [m]")  # its x axis is the panel's
    assert figure_problems(fig) == []
    fig, ax = new_figure()
    ax.bar(["slope", "model"], [1.0, 2.0])  # categories name themselves
    ax.set_ylabel("rate [rad/s]")
    assert figure_problems(fig) == []
    fig, ax = new_figure()
    image = ax.pcolormesh(np.ones((3, 3)))
    ax.set(xlabel="u [m]", ylabel="v [m]")
    fig.colorbar(image, ax=ax, label="angle")
    assert any("'angle' has no unit" in p for p in figure_problems(fig))


def test_save_figure_refuses_a_bad_figure_only_when_checking(tmp_path, monkeypatch):
    monkeypatch.setenv(CHECK_ENV, "1")
    fig, _ = _line_figure(xlabel="t [s]")
    with pytest.raises(FigureCheckError, match=r"bad.png: panel 0: y axis has no label"):
        save_figure(fig, tmp_path / "bad.png")
    assert not (tmp_path / "bad.png").exists()
    monkeypatch.setenv(CHECK_ENV, "0")
    fig, _ = _line_figure(xlabel="t [s]")
    assert save_figure(fig, tmp_path / "bad.png").is_file()


# --------------------------------------------------------------------------- every concept's figures

#: the CNUSAIL plotting paths that tests/test_render.py's run of every scenario kind (which checks
#: its figures too) does not reach: the pointing and deorbit branches and the lifetime figures
PLOTTING_RUNS = [
    ("cnusail/pd_vs_eigenaxis.toml", ["sim.duration_s=30"]),
    ("cnusail/deorbit_recalc.toml", ["sim.duration_s=30"]),
    pytest.param("cnusail/lifetime.toml", [], marks=pytest.mark.slow),  # 40 s: the whole decay analysis
]


@pytest.mark.parametrize("config, overrides", PLOTTING_RUNS)
def test_every_figure_of_a_run_is_readable(tmp_path, monkeypatch, config, overrides):
    monkeypatch.setenv(CHECK_ENV, "1")
    concept, _, rest = config.partition("/")
    cfg = load_config(
        CONCEPTS / concept / "configs" / rest, [*overrides, "sim.progress=false", "sim.checkpoint_every_s=0"]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        outcome = run_scenario(cfg, tmp_path / "run", progress=False)
    assert outcome.status == "completed", outcome.get("status_message")
    assert list((tmp_path / "run").glob("*.png")), "no figure written"


def test_error_bars_are_named_by_their_label():
    fig, ax = new_figure()
    for k, colour in enumerate(("C0", "C1", "C2")):
        ax.errorbar([k], [1.0], xerr=[[0.1], [0.2]], fmt="s", color=colour, capsize=4, label=f"case {k}")
    ax.set(xlabel="altitude [km]", ylabel="lifetime [days]")
    ax.legend()
    assert figure_problems(fig) == []
    fig, ax = new_figure()
    for k, colour in enumerate(("C0", "C1")):
        ax.errorbar([k], [1.0], xerr=[[0.1], [0.2]], fmt="s", color=colour)
    ax.set(xlabel="altitude [km]", ylabel="lifetime [days]")
    assert any("unlabelled line colours" in p for p in figure_problems(fig))
