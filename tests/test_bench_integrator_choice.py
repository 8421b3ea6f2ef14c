"""scripts/integrator_choice.py: the agreement rule, the order of the candidates, the whole-run check
(no runs), and every studied config shipping the setting the committed table names for it."""

from __future__ import annotations

import json
import math
import sys

import pytest

from magsail_mj.config import load_config
from tests.conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
import integrator_choice as ic  # noqa: E402
from integrator_choice import CHOICES, Choice, Setting, compare  # noqa: E402

CHOICE = Choice("x.toml", 1.0, attitude_tol=1e-3, structural_tol=1e-2)
REF = {"rotation_x1_final_rad": 1.0, "surface_sd_max_m": 2.0, "off_axis_rotation_max_rad": 1e-12}


def _run(**summary: float) -> dict:
    return {"status": "completed", "summary": {**REF, **summary}}


def test_attitude_figures_use_the_attitude_tolerance():
    assert compare(CHOICE, REF, _run(rotation_x1_final_rad=1.0009), record_s=1.0)["agrees"]
    out = compare(CHOICE, REF, _run(rotation_x1_final_rad=1.0011), record_s=1.0)
    assert not out["agrees"] and out["worst_key"] == "rotation_x1_final_rad"
    assert out["worst_over_tol"] == pytest.approx(1.1, rel=1e-9)


def test_structural_figures_use_the_structural_tolerance():
    assert compare(CHOICE, REF, _run(surface_sd_max_m=2.019), record_s=1.0)["agrees"]
    assert not compare(CHOICE, REF, _run(surface_sd_max_m=2.021), record_s=1.0)["agrees"]


def test_near_zero_figures_are_listed_not_compared():
    out = compare(CHOICE, REF, _run(off_axis_rotation_max_rad=5e-12), record_s=1.0)
    assert out["agrees"] and out["near_zero"] == ["off_axis_rotation_max_rad"]


def test_a_missing_figure_or_a_run_that_did_not_complete_disagrees():
    assert not compare(CHOICE, REF, {"status": "completed", "summary": {"surface_sd_max_m": 2.0}}, record_s=1.0)[
        "agrees"
    ]
    out = compare(CHOICE, REF, {"status": "diverged"}, record_s=1.0)
    assert not out["agrees"] and math.isinf(out["worst_over_tol"])


def test_expected_cost_counts_stages_per_simulated_second():
    assert Setting("RK4", 0.1, "start").expected_cost() == pytest.approx(40.0)
    assert Setting("Euler", 0.2, "start").expected_cost() == pytest.approx(5.0)
    assert Setting("Euler", 0.2, "midpoint").expected_cost() == pytest.approx(8.0)


def test_every_row_names_a_shipped_config():
    for c in CHOICES:
        assert (REPO / "magsail_mj" / "concepts" / c.config).is_file(), c.config


TABLE = REPO / "docs" / "_static" / "bench" / "integrator_choice.json"
ROWS = json.loads(TABLE.read_text())


def _setting(config: str) -> str:
    """The label (``"RK4 0.2 s midpoint"``) of what ``config`` ships."""
    sim = load_config(ic.CONCEPTS / config).sim
    return ic.Setting(sim.integrator, float(sim.timestep_s), sim.load_timing).label()


def test_the_table_covers_every_row_of_the_study():
    assert sorted(r["config"] for r in ROWS) == sorted(c.config for c in ic.CHOICES)


@pytest.mark.parametrize("row", ROWS, ids=lambda r: r["config"])
def test_each_config_ships_the_chosen_setting_or_states_why_not(row):
    """A config ships the study's choice once the whole run accepted it, and says so beside its
    ``[sim]`` table; otherwise it keeps the setting the study started from (the table says why)."""
    shipped = _setting(row["config"])
    choice = next(c for c in ic.CHOICES if c.config == row["config"])
    assert (row.get("keep") or "") == choice.keep, "the table was made with the script's current reasons"
    if ic.shipped_setting(row) != "chosen":
        assert shipped == row["current"]["label"], ic.shipped_setting(row)
        return
    assert shipped == row["chosen"]["label"] == row["confirmed"]["chosen"]["label"]
    assert row["confirmed"]["accepted"], "the chosen setting was checked over the whole run"
    text = (ic.CONCEPTS / row["config"]).read_text()
    assert "# Integrator and step:" in text, "the choice is documented beside the config's [sim] table"


def test_sampled_times_and_record_shares_agree_within_their_resolution():
    assert ic.absolute_tol("wheel_time_above_unload_x_s", record_s=1.0, duration_s=1800.0) == 1.0
    assert ic.absolute_tol("surface_sd_period_s", record_s=2.0, duration_s=1800.0) == 2.0
    assert ic.absolute_tol("sat_fraction", record_s=1.0, duration_s=2000.0) == pytest.approx(5e-4)
    for rate in ("omega_norm_max_rad_s", "max_slew_rate_deg_s", "tip_speed_final_m_s", "twist_share_at_max_sd"):
        assert ic.absolute_tol(rate, record_s=1.0, duration_s=1800.0) == 0.0


def test_compare_applies_the_larger_of_the_relative_tolerance_and_the_resolution():
    choice = ic.Choice("x.toml", 1800.0, attitude_tol=1e-3, structural_tol=1e-2)
    ref = {"wheel_time_above_unload_x_s": 53.0, "omega_norm_max_rad_s": 2.0, "surface_sd_max_m": 0.03}
    one_record_off = {"wheel_time_above_unload_x_s": 52.0, "omega_norm_max_rad_s": 2.0, "surface_sd_max_m": 0.03}
    verdict = ic.compare(choice, ref, {"status": "completed", "summary": one_record_off}, record_s=1.0)
    assert verdict["agrees"] and verdict["worst_over_tol"] == pytest.approx(1.0)
    two_records_off = {**one_record_off, "wheel_time_above_unload_x_s": 51.0}
    verdict = ic.compare(choice, ref, {"status": "completed", "summary": two_records_off}, record_s=1.0)
    assert not verdict["agrees"] and verdict["worst_key"] == "wheel_time_above_unload_x_s"
    rate_off = {**one_record_off, "omega_norm_max_rad_s": 2.0 * (1 + 2e-3)}
    verdict = ic.compare(choice, ref, {"status": "completed", "summary": rate_off}, record_s=1.0)
    assert not verdict["agrees"] and verdict["worst_over_tol"] == pytest.approx(2.0)
    structure_off = {**one_record_off, "surface_sd_max_m": 0.03 * 1.005}  # within the structural 1 %
    assert ic.compare(choice, ref, {"status": "completed", "summary": structure_off}, record_s=1.0)["agrees"]
    failed = ic.compare(choice, ref, {"status": "structure_failed"}, record_s=1.0)
    assert not failed["agrees"] and math.isinf(failed["worst_over_tol"])


def test_the_whole_run_check_accepts_no_figure_made_worse():
    row = ROWS[0]

    def run(rate: float, energy: float) -> dict:
        return {"status": "completed", "summary": {"rate_mean_last_orbit_rad_s": rate, "mtq_energy_J": energy}}

    whole = {"config": row["config"], "duration_s": 1000.0}
    better = ic.whole_run_verdict(whole | {"runs": [run(1e-3, 500.0), run(1.003e-3, 500.0), run(1.002e-3, 500.1)]})
    assert better["accepted"] and better["worse"] == []
    worse = ic.whole_run_verdict(whole | {"runs": [run(1e-3, 500.0), run(1.001e-3, 500.0), run(1.002e-3, 500.0)]})
    assert not worse["accepted"] and worse["worse"] == ["rate_mean_last_orbit_rad_s"]


def test_a_step_that_splits_a_record_is_refused():
    assert ic.keeps_record_interval(ic.Setting("RK4", 0.2, "start"), 1.0)
    assert ic.keeps_record_interval(ic.Setting("RK4", 0.4, "start"), 2.0)
    assert not ic.keeps_record_interval(ic.Setting("RK4", 0.4, "start"), 1.0)
    assert not ic.keeps_record_interval(ic.Setting("Euler", 2.0, "start"), 1.0)


def test_the_performance_page_shows_the_committed_table():
    page = (REPO / "docs" / "performance.md").read_text()
    assert ic.markdown(ROWS) in page, "docs/performance.md: paste integrator_choice.md of the committed table"
