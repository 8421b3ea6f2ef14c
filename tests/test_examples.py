"""The examples run as shipped (short durations) and do what they say."""

from __future__ import annotations


from tests.conftest import REPO, load_file_module


def _example(name: str):
    return load_file_module("examples", name)


def test_custom_controller_damps_the_tumble(monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    out = _example("custom_controller").main(30.0)
    assert out["status"] == "completed"
    assert out["rate_end_deg_s"] < 0.9 * out["rate_start_deg_s"]
    assert "rate_end_deg_s" in capsys.readouterr().out
