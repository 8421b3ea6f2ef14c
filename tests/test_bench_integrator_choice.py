"""scripts/integrator_choice.py: the agreement rule and the order of the candidates (no runs)."""

from __future__ import annotations

import math
import sys

import pytest

from tests.conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
from integrator_choice import CHOICES, Choice, Setting, compare  # noqa: E402

CHOICE = Choice("x.toml", 1.0, attitude_tol=1e-3, structural_tol=1e-2)
REF = {"rotation_x1_final_rad": 1.0, "surface_sd_max_m": 2.0, "off_axis_rotation_max_rad": 1e-12}


def _run(**summary: float) -> dict:
    return {"status": "completed", "summary": {**REF, **summary}}


def test_attitude_figures_use_the_attitude_tolerance():
    assert compare(CHOICE, REF, _run(rotation_x1_final_rad=1.0009))["agrees"]
    out = compare(CHOICE, REF, _run(rotation_x1_final_rad=1.0011))
    assert not out["agrees"] and out["worst_key"] == "rotation_x1_final_rad"
    assert out["worst_over_tol"] == pytest.approx(1.1, rel=1e-9)


def test_structural_figures_use_the_structural_tolerance():
    assert compare(CHOICE, REF, _run(surface_sd_max_m=2.019))["agrees"]
    assert not compare(CHOICE, REF, _run(surface_sd_max_m=2.021))["agrees"]


def test_near_zero_figures_are_listed_not_compared():
    out = compare(CHOICE, REF, _run(off_axis_rotation_max_rad=5e-12))
    assert out["agrees"] and out["near_zero"] == ["off_axis_rotation_max_rad"]


def test_a_missing_figure_or_a_run_that_did_not_complete_disagrees():
    assert not compare(CHOICE, REF, {"status": "completed", "summary": {"surface_sd_max_m": 2.0}})["agrees"]
    out = compare(CHOICE, REF, {"status": "diverged"})
    assert not out["agrees"] and math.isinf(out["worst_over_tol"])


def test_expected_cost_counts_stages_per_simulated_second():
    assert Setting("RK4", 0.1, "start").expected_cost() == pytest.approx(40.0)
    assert Setting("Euler", 0.2, "start").expected_cost() == pytest.approx(5.0)
    assert Setting("Euler", 0.2, "midpoint").expected_cost() == pytest.approx(8.0)


def test_every_row_names_a_shipped_config():
    for c in CHOICES:
        assert (REPO / "magsail_mj" / "concepts" / c.config).is_file(), c.config
