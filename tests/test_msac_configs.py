"""MSAC configs and run folders: validation, sweep files against their
base, end-to-end runs through ``run_scenario`` (multibody, lumped, sweep)."""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest

from magsail_mj.concepts.msac.reference import exact_rotation_path, lumped_theta
from magsail_mj.concepts import TASKS
from magsail_mj.config import ConfigError, load_config, parse_config
from magsail_mj.export import read_timeseries
from magsail_mj.records import STORE_NAME
from magsail_mj.run import run_scenario
from magsail_mj.scenario import build_scenario
from magsail_mj.concepts.msac.tasks import build_msac_scenario
from magsail_mj.concepts.msac.tasks import LumpedTask, MultibodyTask, SweepTask
from tests.conftest import REPO

MODELS = REPO / "magsail_mj" / "concepts" / "msac" / "configs"
SWEEPS = sorted((MODELS / "sweeps").glob("*.toml"))
ISSUE_KEYS = (
    "secular_rate_rad_s",
    "predicted_rate_lumped_rad_s",
    "predicted_rate_exact_rad_s",
    "net_rotation_rad",
    "angular_momentum_drift",
)
SPEC_KEYS = (
    "bus_mass_kg",
    "bus_izz_kgm2",
    "wing_mass_kg",
    "wing_I_rest_hinge_kgm2",
    "wing_I_e_hinge_kgm2",
    "wing_I_c_hinge_kgm2",
    "wing_I_rest_centre_kgm2",
    "wing_I_e_centre_kgm2",
    "wing_I_c_centre_kgm2",
    "theta_gamma_eq6_model_rad",
    "theta_gamma_eq6_stretch_rad",
    "omega_gamma_eq7_rad_s",
    "theta_gamma_exact_rad",
    "theta_gamma_mujoco_rad",
    "theta_gamma_mujoco_std_rad",
    "theta_gamma_first_cycle_rad",
    "rate_slope_rad_s",
    "rate_filtered_mean_rad_s",
    "rate_estimates_rel_diff",
    "mujoco_vs_exact_rel_diff",
    "angmom_drift_max_Nms",
    "hinge_torque_peak_Nm",
    "slide_force_peak_N",
    "yaw_unwrapped_final_rad",
    "cycles_simulated",
    "simulated_time_s",
    "wall_time_s",
)


def test_scenario_ids_of_the_spec_exist():
    for sid in ("lumped", "paper_1khz", "paper_1khz_stroke10", "slow_1hz", "lumped_limit", "mirror_wings"):
        assert (MODELS / f"{sid}.toml").is_file() and (MODELS / f"{sid}.xml").is_file(), sid
    assert {p.stem for p in SWEEPS} >= {
        "stroke",
        "extension",
        "areal_density",
        "bus_inertia",
        "hinge_offset",
        "phase_fractions",
        "frequency",
    }


def test_paper_config_values():
    cfg = load_config(MODELS / "paper_1khz.toml")
    assert (cfg.sim.duration_s, cfg.sim.timestep_s, cfg.sim.integrator) == (600.0, 5e-6, "RK4")
    assert (cfg.cycle.frequency_Hz, cfg.cycle.bend_a_deg, cfg.cycle.bend_b_deg, cfg.cycle.extension_frac) == (
        1000.0,
        10.0,
        -10.0,
        0.01,
    )
    assert cfg.wings.length_m == 8.0 and cfg.wings.width_m == 3.0
    assert load_config(MODELS / "paper_1khz_stroke10.toml").cycle.bend_b_deg == 0.0


@pytest.mark.parametrize("path", SWEEPS, ids=lambda p: p.stem)
def test_sweep_files_equal_their_base(path):
    tree = tomllib.loads(path.read_text())
    base = tomllib.loads((MODELS / f"{tree['sweep']['base']}.toml").read_text())
    for key in ("scenario", "description", "sweep"):
        tree.pop(key, None)
        base.pop(key, None)
    assert tree == base
    cfg = load_config(path)
    assert cfg.scenario == "sweep" and len(cfg.sweep.points) >= 2


@pytest.mark.parametrize(
    "override, words",
    [
        ("sim.timestep_s=3e-6", ["timestep_s", "integer multiple"]),
        ("cycle.phase_fractions=[0.5, 0.1, 0.4, 0.1]", ["phase_fractions"]),
        ("wings.layout='diagonal'", ["wings.layout"]),
        ("cycle.bogus=1", ["cycle.bogus", "unknown key"]),
        ("bus.size_m=[2.0, 0.0, 3.0]", ["size_m"]),
    ],
)
def test_bad_values_are_reported_with_their_key(override, words):
    with pytest.raises(ConfigError) as err:
        load_config(MODELS / "paper_1khz.toml", [override])
    for w in words:
        assert w in str(err.value)


def test_sweep_keys_must_exist():
    tree = tomllib.loads((MODELS / "sweeps" / "stroke.toml").read_text())
    tree["sweep"]["keys"] = ["cycle.bend_c_deg"]
    with pytest.raises(ConfigError, match="cycle.bend_c_deg"):
        parse_config(tree)


def test_sweep_table_only_with_sweep_scenario():
    tree = tomllib.loads((MODELS / "sweeps" / "stroke.toml").read_text())
    tree["scenario"] = "multibody"
    with pytest.raises(ConfigError, match="sweep"):
        parse_config(tree)


def test_multibody_run_folder(tmp_path):
    cfg = load_config(MODELS / "paper_1khz.toml", ["sim.duration_s=0.006", "sim.record_every=20"])
    out = run_scenario(cfg, tmp_path / "run", progress=False)
    run = out.run_dir
    assert (run / STORE_NAME).is_dir()
    for name in (
        "model.xml",
        "summary.json",
        "manifest.json",
        "cycle_diagram.png",
        "attitude_angles.png",
        "omega_world.png",
        "rate_comparison.png",
        "cycle_increments.png",
    ):
        assert (run / name).is_file(), name
    summary = json.loads((run / "summary.json").read_text())
    for key in ISSUE_KEYS + SPEC_KEYS:
        assert key in summary and summary[key] is not None, key
    assert summary["cycles_simulated"] == 6
    assert abs(summary["mujoco_vs_exact_rel_diff"]) < 5e-3
    man = json.loads((run / "manifest.json").read_text())
    params = man["parameters"]
    assert params["cycle.frequency_Hz"]["source"] == "paper"
    assert params["bus.mass_kg"]["source"] == "placeholder"
    assert man["solver"]["steps_per_cycle"] == 200 and man["render"]["overlay"] == ["yaw_unwrapped_rad", "phase"]
    z = read_timeseries(run)
    assert z["qpos"].shape == (z["t"].size, 11)
    assert z["strobe_t"].size == 7 and z["yaw_unwrapped_rad"].shape == z["t"].shape


def test_lumped_scenario_summary(tmp_path):
    cfg = load_config(MODELS / "lumped.toml")
    out = run_scenario(cfg, tmp_path / "lumped", progress=False)
    sc = build_msac_scenario(cfg)
    P = sc.planar
    c_e, c_c = 0.08 + 4.0, 4.0
    I_e, I_c = P.wing_icm_kgm2 + 60 * c_e**2, P.wing_icm_kgm2 + 60 * c_c**2
    eq6 = lumped_theta(I_e=2 * I_e, I_c=2 * I_c, I_sat=2000.0, phi_a=math.radians(10), phi_b=math.radians(-10))
    assert out["theta_gamma_eq6_model_rad"] == pytest.approx(eq6, rel=1e-12)
    assert out["predicted_rate_lumped_rad_s"] == pytest.approx(eq6 * 1000.0, rel=1e-12)
    assert out["theta_gamma_exact_rad"] == pytest.approx(exact_rotation_path(P, sc.path.waypoints).sum(), rel=1e-12)
    assert out["theta_gamma_eq6_stretch_rad"] == pytest.approx(
        (2 * 60 * (8.08**2 - 8.0**2) / 3) * math.radians(20) / 2000.0, rel=1e-12
    )


def test_sweep_scenario(tmp_path):
    tree = tomllib.loads((MODELS / "sweeps" / "frequency.toml").read_text())
    tree["sweep"]["points"] = [[10.0], [1000.0]]
    tree["sweep"]["cycles"] = 4
    cfg = parse_config(tree)
    out = run_scenario(cfg, tmp_path / "sweep", progress=False)
    assert (out.run_dir / "sweep.png").is_file()
    th = np.array(out["sweep_theta_gamma_mujoco_rad"])
    ex = np.array(out["sweep_theta_gamma_exact_rad"])
    assert th.shape == (2,) and np.all(np.abs(th / ex - 1) < 5e-3)
    # per-cycle rotation flat in frequency, rate proportional to it (T6)
    assert out["sweep_secular_rate_rad_s"][1] / out["sweep_secular_rate_rad_s"][0] == pytest.approx(100, rel=5e-3)


@pytest.mark.parametrize(
    "path, cls",
    [("lumped.toml", LumpedTask), ("slow_1hz.toml", MultibodyTask), (SWEEPS[0].relative_to(MODELS), SweepTask)],
)
def test_every_kind_builds_its_registered_task_class(path, cls):
    """One task class per ``scenario``, registered under ``("msac", scenario)`` and found by build_scenario."""
    cfg = load_config(MODELS / path)
    assert TASKS[("msac", cfg.scenario)] is cls
    assert type(build_scenario(cfg)) is cls
