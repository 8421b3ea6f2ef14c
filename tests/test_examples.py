"""The examples run as shipped (short durations) and do what they say."""

from __future__ import annotations

from magsail_mj.control.detumble_plugins import unregister_detumble_law
from tests.conftest import REPO, load_file_module


def _example(name: str):
    return load_file_module("examples", name)


def test_custom_controller_damps_the_tumble(monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    out = _example("custom_controller").main(30.0)
    assert out["status"] == "completed"
    assert out["rate_end_deg_s"] < 0.9 * out["rate_start_deg_s"]
    assert "rate_end_deg_s" in capsys.readouterr().out


def test_detumble_law_plugin_runs_beside_the_shipped_laws(monkeypatch, capsys):
    """Two worlds per law over 600 s: the plug-in's worlds run and its rates fall (a law that gets
    the rate or the field wrong in sign would spin the cubesat up)."""
    monkeypatch.chdir(REPO)
    try:
        out = _example("detumble_law_plugin").main(worlds=2, duration_s=600.0)
    finally:
        unregister_detumble_law("field_rate_damper")
    assert set(out) == {"proportional", "b_cross", "field_rate_damper"}
    assert out["field_rate_damper"]["median_end_rate_deg_s"] < 6.0
    assert "field_rate_damper" in capsys.readouterr().out
