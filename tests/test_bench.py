"""``magsail bench`` / :func:`magsail_mj.bench.bench`: the JSON it prints, its internal consistency
and its errors. No timing thresholds: only relations that hold by construction (the ratio is the
quotient of the two medians, the parts sum to the instrumented pass), plus one loose bound between
the instrumented and the uninstrumented pass (stated below)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from magsail_mj.bench import PART_NAMES, BenchRunError, bench
from magsail_mj.cli import main
from magsail_mj.config import load_config

ROOT = Path(__file__).resolve().parents[1]
CUBESAT = str(ROOT / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")
CUBESAT_DT_S = load_config(CUBESAT).sim.timestep_s  # the shipped step (its integrator choice)
LIFETIME = str(ROOT / "magsail_mj/concepts/cnusail/configs/lifetime.toml")
MSAC = str(ROOT / "magsail_mj/concepts/msac/configs/slow_1hz.toml")

KEYS = {
    "us_per_step": float,
    "mj_step_us": float,
    "ratio_to_mj_step": float,
    "parts_us": dict,
    "steps_per_s": float,
    "realtime_factor": float,
    "peak_rss_mb": float,
    "steps": int,
    "mj_step_native_us": float,
    "instrumented_us_per_step": float,
    "us_per_step_runs": list,
    "mj_step_us_runs": list,
    "timestep_s": float,
    "duration_s": float,
    "run_setup_s": float,
}

# the instrumented pass adds a wrapper call (≈ 0.1–0.3 µs quiet, ≈ 1 µs on a loaded machine) per
# timed part and call (≈ 10 per cubesat step of ≈ 60–300 µs); on a shared machine passes also
# differ by load. Bound: it costs at most this many times the slowest all-in pass.
INSTRUMENTED_SLACK = 5.0


@pytest.fixture(scope="module")
def cubesat() -> dict:
    return bench(CUBESAT, duration_s=10.0, repeat=3)


def test_keys_and_types(cubesat):
    for key, kind in KEYS.items():
        assert isinstance(cubesat[key], kind), key
    json.dumps(cubesat, allow_nan=False)  # JSON-able, finite
    assert cubesat["steps"] == round(10.0 / CUBESAT_DT_S) and cubesat["duration_s"] == pytest.approx(10.0, rel=1e-12)
    assert len(cubesat["us_per_step_runs"]) == len(cubesat["mj_step_us_runs"]) == 3
    assert cubesat["integrator"] == "RK4" and cubesat["timestep_s"] == CUBESAT_DT_S


def test_ratio_and_rates_follow_from_the_medians(cubesat):
    us, mj = cubesat["us_per_step"], cubesat["mj_step_us"]
    assert us == pytest.approx(sorted(cubesat["us_per_step_runs"])[1], rel=1e-15)
    assert mj == pytest.approx(sorted(cubesat["mj_step_us_runs"])[1], rel=1e-15)
    assert cubesat["ratio_to_mj_step"] == pytest.approx(us / mj, rel=1e-12)
    assert cubesat["steps_per_s"] == pytest.approx(1e6 / us, rel=1e-12)
    assert cubesat["realtime_factor"] == pytest.approx(CUBESAT_DT_S / (us * 1e-6), rel=1e-12)
    assert us > 0 and mj > 0 and cubesat["mj_step_native_us"] > 0 and cubesat["peak_rss_mb"] > 0


def test_parts_of_the_cubesat(cubesat):
    parts = cubesat["parts_us"]
    assert set(parts) == {
        "load: cubesat_disturbances",
        "load: magnetorquer",
        "controller",
        "environment",
        "kinematics",
        "probes",
        "recorder",
        "mj_step",
        "loop",
    }
    assert set(parts) - {"load: cubesat_disturbances", "load: magnetorquer"} <= set(PART_NAMES)
    measured = {k: v for k, v in parts.items() if k != "loop"}
    assert all(v > 0 for v in measured.values())
    total = cubesat["instrumented_us_per_step"]
    # the parts are the instrumented pass: they sum to it (round-off only), and the timed parts
    # fit in it (the loop remainder is not negative)
    assert sum(parts.values()) == pytest.approx(total, rel=1e-9)
    assert sum(measured.values()) <= total * (1 + 1e-12)
    assert total <= INSTRUMENTED_SLACK * max(cubesat["us_per_step_runs"])


def test_msac_runner_has_the_same_report():
    out = bench(MSAC, duration_s=0.05, overrides=["sim.record_every=1"])
    assert out["concept"] == "msac" and out["steps"] == 10
    assert {"recorder", "mj_step", "loop"} <= set(out["parts_us"])
    assert out["ratio_to_mj_step"] == pytest.approx(out["us_per_step"] / out["mj_step_us"], rel=1e-12)
    assert sum(out["parts_us"].values()) == pytest.approx(out["instrumented_us_per_step"], rel=1e-9)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"duration_s": -1.0}, "duration_s"),
        ({"duration_s": math.nan}, "duration_s"),
        ({"duration_s": "5"}, "duration_s"),
        ({"repeat": 0}, "repeat"),
        ({"repeat": 1.5}, "repeat"),
    ],
)
def test_bad_options_are_named(kwargs, name):
    with pytest.raises(ValueError, match=f"^{name}:"):
        bench(CUBESAT, **kwargs)


def test_a_kind_without_steps_is_refused():
    with pytest.raises(ValueError, match="^config: .*lifetime.*no stepped MuJoCo run"):
        bench(LIFETIME)


# ------------------------------------------------------------------------------------ CLI


def test_cli_prints_one_json_object(capsys):
    code = main(["bench", CUBESAT, "--duration-s", "2", "--set", "sim.record_every=5", "--set", "sim.timestep_s=0.1"])
    out = capsys.readouterr().out
    assert code == 0
    assert out.count("\n") == 1
    obj = json.loads(out)
    assert obj["config"] == CUBESAT and obj["steps"] == 20
    for key in (
        "us_per_step",
        "mj_step_us",
        "ratio_to_mj_step",
        "parts_us",
        "steps_per_s",
        "realtime_factor",
        "peak_rss_mb",
    ):
        assert key in obj


@pytest.mark.parametrize(
    "argv, named",
    [
        (["--duration-s", "0"], "--duration-s"),
        (["--duration-s", "x"], "--duration-s"),
        (["--repeat", "0"], "--repeat"),
        (["--set", "sim.timestep_s=-1"], "sim.timestep_s"),
    ],
)
def test_cli_errors_name_the_option(capsys, argv, named):
    code = main(["bench", CUBESAT, *argv])
    err = capsys.readouterr()
    assert code == 2 and err.out == ""
    assert err.err.startswith("error: ") and named in err.err and "Traceback" not in err.err


def test_cli_missing_config_and_lifetime(capsys):
    assert main(["bench", "no_such_config.toml"]) == 2
    assert "config: no such file" in capsys.readouterr().err
    assert main(["bench", LIFETIME]) == 2
    assert "no stepped MuJoCo run" in capsys.readouterr().err


@pytest.mark.parametrize("status, code", [("diverged", 3), ("failed", 1), ("structure_failed", 1)])
def test_cli_exit_status_of_a_run_that_did_not_complete(capsys, monkeypatch, status, code):
    def ends(*args, **kwargs):
        raise BenchRunError(status, "at t = 1 s")

    monkeypatch.setattr("magsail_mj.verbs.bench.bench", ends)
    assert main(["bench", CUBESAT, "--duration-s", "1"]) == code
    err = capsys.readouterr()
    assert err.out == "" and status in err.err
