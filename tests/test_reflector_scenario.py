"""Reflector plate model and scenarios (Robb et al. 2020, Table 1, Eqs. 11–15): inertia, B-dot laws, a SciPy
``solve_ivp`` reference of the detumbling rigid body, config validation, short end-to-end runs."""

from __future__ import annotations

import json
import math

import magsail_mj  # noqa: F401  (before mujoco: GL backend choice)
import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from magsail_mj.concepts import TASKS
from magsail_mj.config import ConfigError, load_config, parse_config
from magsail_mj.concepts.reflector.bdot import PlateBdotController
from magsail_mj.export import read_timeseries
from magsail_mj.loads.base import StepState
from magsail_mj.loads.body_torque import OrbitGravityGradientLoad
from magsail_mj.concepts.reflector.mjcf import PlateModelParams, build_plate_spec, plate_mass_properties
from magsail_mj.quaternion import quat_to_matrix
from magsail_mj.records import STORE_NAME
from magsail_mj.run import run_scenario
from magsail_mj.scenario import build_scenario
from magsail_mj.concepts.reflector.caps import CapSweepRunner, cap_grid
from magsail_mj.concepts.reflector.tasks import DetumbleTask, PitchCapsTask, PitchTask
from tests.conftest import REPO

DETUMBLE = REPO / "magsail_mj" / "concepts" / "reflector" / "configs" / "detumble.toml"
TRACK100 = REPO / "magsail_mj" / "concepts" / "reflector" / "configs" / "tracking_100g.toml"


def test_plate_inertia_with_thickness_and_round_trip():
    m, I = plate_mass_properties(side_m=100.0, areal_density_kg_m2=0.1, thickness_m=1.0)
    assert m == pytest.approx(1000.0)
    assert I[0] == I[1] == pytest.approx(1000.0 * (100.0**2 + 1.0) / 12)
    assert I[2] == pytest.approx(1000.0 * 100.0**2 / 6)
    assert I[0] + I[1] > I[2] and (I[0] + I[1] - I[2]) / I[2] == pytest.approx(1e-4)
    spec = build_plate_spec(PlateModelParams(areal_density_kg_m2=0.01))
    model = mujoco.MjModel.from_xml_string(spec.to_xml())
    b = model.body("plate").id
    assert model.body_mass[b] == pytest.approx(100.0)
    assert np.allclose(model.body_inertia[b], I / 10)
    assert model.opt.gravity.tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="inertia_thickness_m"):
        plate_mass_properties(side_m=100.0, areal_density_kg_m2=0.1, thickness_m=0.0)


def _bdot(law):
    return PlateBdotController(
        law=law,
        m_max_Am2=37500.0,
        T_max_Nm=1.125,
        gain=1.25e11,
        I_max_A=10.0,
        field_body=lambda t, R: R.T @ np.array([0, 0, 30e-6]),
        body_id=1,
        period_s=0.5,
    )


def test_bdot_laws_dissipate_or_do_no_work():
    rng = np.random.default_rng(0)
    for _ in range(100):
        w = rng.normal(size=3) * 0.05
        B = rng.normal(size=3) * 3e-5
        c = _bdot("dipole").command(w, B)
        assert c.dipole_body[2] == 0 and np.all(np.abs(c.dipole_body) <= 37500.0)
        assert abs(c.torque_body @ B) < 1e-12 * np.linalg.norm(c.torque_body) * np.linalg.norm(B) + 1e-30
        assert c.torque_body @ w <= 1e-15  # removes energy
        assert np.all(np.abs(c.currents_A) <= 10.0)
        p = _bdot("printed").command(w, B)
        assert abs(p.torque_body @ w) < 1e-12 * np.linalg.norm(p.torque_body) * np.linalg.norm(w)  # no work
        assert np.linalg.norm(p.torque_body) <= 1.125 * (1 + 1e-12)
        n = _bdot("norm_cap").command(w, B)
        assert n.torque_body @ w <= 1e-15 and np.linalg.norm(n.torque_body) <= 1.125 * (1 + 1e-12)
    # unsaturated dipole law: T = k (ω × B) × B restricted to the xy dipoles
    w, B = np.array([1e-9, -2e-9, 0.0]), np.array([0.0, 0.0, 3e-5])
    c = _bdot("dipole").command(w, B)
    assert not c.saturated.any()
    assert np.allclose(c.torque_body, 1.25e11 * np.cross(np.cross(w, B), B))


def _euler_rhs(I, T_w):
    def rhs(t, y):
        q, w = y[:4], y[4:]
        R = quat_to_matrix(q / np.linalg.norm(q))
        T_b = R.T @ T_w
        wd = (T_b - np.cross(w, I * w)) / I
        qw, qx, qy, qz = q
        qd = 0.5 * np.array(
            [
                -qx * w[0] - qy * w[1] - qz * w[2],
                qw * w[0] + qy * w[2] - qz * w[1],
                qw * w[1] - qx * w[2] + qz * w[0],
                qw * w[2] + qx * w[1] - qy * w[0],
            ]
        )
        return np.concatenate([qd, wd])

    return rhs


def test_detumble_matches_scipy_solve_ivp_reference():
    """MuJoCo RK4 + xfrc_applied against solve_ivp (rtol 1e-10) of I ω̇ + ω × Iω = T, q̇ = ½ q ⊗ (0, ω),
    with the same zero-order-held world torque over each step."""
    cfg = load_config(
        DETUMBLE,
        [
            "sim.duration_s=300",
            "sim.timestep_s=0.5",
            "sim.record_every=1",
            "sim.progress=false",
            "control.omega_k_rad_s=0.1",
        ],
    )
    sc = build_scenario(cfg)
    res = sc.simulation().run()
    rec = res.records
    I = sc.inertia
    ctl = sc.make_controller()
    q0, w0 = sc.initial_state()
    y = np.concatenate([q0, w0])
    dt = cfg.sim.timestep_s
    for k in range(len(rec["t"]) - 1):
        q = y[:4] / np.linalg.norm(y[:4])
        R = quat_to_matrix(q)
        T_b = ctl.command(y[4:], R.T @ np.array([0, 0, 30e-6])).torque_body
        sol = solve_ivp(_euler_rhs(I, R @ T_b), (0.0, dt), y, method="DOP853", rtol=1e-10, atol=1e-13)
        y = sol.y[:, -1]
    w_mj = rec["qvel"][-1][3:6]
    q_mj = rec["qpos"][-1][3:7]
    assert np.allclose(w_mj, y[4:], rtol=0, atol=1e-9 * np.linalg.norm(w0))
    assert np.allclose(q_mj, y[:4] / np.linalg.norm(y[:4]), atol=1e-8)
    # and the torque really acted: |ω| dropped
    assert np.linalg.norm(w_mj) < np.linalg.norm(w0) - 1e-5


def test_detumble_continuous_law_reference_agrees_with_zoh_run():
    """Continuous-time B-dot (solve_ivp, rtol 1e-8) vs the 0.5 s zero-order-hold run over 2000 s."""
    cfg = load_config(
        DETUMBLE, ["sim.duration_s=2000", "sim.timestep_s=0.5", "sim.record_every=100", "sim.progress=false"]
    )
    sc = build_scenario(cfg)
    res = sc.simulation().run()
    ctl = sc.make_controller()
    I = sc.inertia
    B_w = np.array([0, 0, 30e-6])

    def rhs(t, y):
        q = y[:4] / np.linalg.norm(y[:4])
        R = quat_to_matrix(q)
        T_b = ctl.command(y[4:], R.T @ B_w).torque_body
        return _euler_rhs(I, R @ T_b)(t, y)

    q0, w0 = sc.initial_state()
    sol = solve_ivp(rhs, (0.0, 2000.0), np.concatenate([q0, w0]), rtol=1e-8, atol=1e-12, max_step=0.5)
    w_ref = sol.y[4:, -1]
    w_mj = res.records["qvel"][-1][3:6]
    dw_ref = np.linalg.norm(w0) - np.linalg.norm(w_ref)
    dw_mj = np.linalg.norm(w0) - np.linalg.norm(w_mj)
    assert dw_mj == pytest.approx(dw_ref, rel=0.01)  # detumbled amount within 1 %


def test_config_validation_names_the_key():
    tree = {
        "concept": "reflector",
        "scenario": "x",
        "kind": "detumble",
        "sim": {"duration_s": 10, "timestep_s": 0.5},
        "field": {"model": "dipole"},
        "control": {"kind": "quat_pd"},
    }
    with pytest.raises(ConfigError) as err:
        parse_config(tree)
    assert "control.kind" in str(err.value) and "field.model" in str(err.value)
    tree["kind"] = "pitch"
    tree["plate"] = {"side_m": 100.5}
    with pytest.raises(ConfigError, match="side_m"):
        parse_config(tree)
    tree["plate"] = {"side_m": 100.0}
    tree["control"]["saturation"] = "box"
    with pytest.raises(ConfigError, match="control.saturation"):
        parse_config(tree)


def test_detumble_smoke_run_writes_the_run_folder(tmp_path):
    cfg = load_config(
        DETUMBLE,
        ["sim.duration_s=120", "sim.timestep_s=0.5", "sim.record_every=4", "sim.progress=false", "render.max_frames=3"],
    )
    out = run_scenario(cfg, tmp_path / "run", video=True)
    assert (out.run_dir / STORE_NAME).is_dir()
    for name in (
        "summary.json",
        "manifest.json",
        "model.xml",
        "video.mp4",
        "omega_norm.png",
        "body_rates.png",
        "torque.png",
        "currents.png",
        "momentum.png",
    ):
        assert (out.run_dir / name).is_file(), name
    s = json.loads((out.run_dir / "summary.json").read_text())
    for key in (
        "time_rate_below_1e-3_s",
        "t_omega_below_1e-2_s",
        "t_omega_below_1e-3_s",
        "t_omega_below_1e-4_s",
        "omega_final_rad_s",
        "sat_fraction_xcoil",
        "sat_fraction_ycoil",
        "t_min_one_cap_s",
        "t_min_two_caps_s",
        "h_along_B_change_Nms",
    ):
        assert key in s
    assert s["omega_final_rad_s"] < s["omega_initial_rad_s"]
    assert abs(s["h_along_B_change_Nms"]) < 1e-6 * s["h_initial_Nms"]  # h·B̂ is conserved
    m = json.loads((out.run_dir / "manifest.json").read_text())
    assert m["inertia_kgm2"][2] == pytest.approx(1e3 * 1e4 / 6) and "A6" in m["assumptions"]


def test_pitch_smoke_run_summary_keys(tmp_path):
    cfg = load_config(TRACK100, ["sim.duration_s=200", "sim.progress=false"])
    out = run_scenario(cfg, tmp_path / "run")
    s = json.loads((out.run_dir / "summary.json").read_text())
    for key in (
        "tracking_lost_first_s",
        "passes_saturated",
        "psi_error_rms_deg",
        "orbit_period_s",
        "t_mid_s",
        "t_err_above_1deg_s",
        "t_err_above_5deg_s",
        "time_err_above_5deg_s",
        "err_max_rad",
        "err_rms_rad",
        "sat_fraction",
        "passes_over_cap",
        "torque_ff_peak_Nm",
    ):
        assert key in s
    assert s["tracking_lost_first_s"] is None and s["err_max_rad"] < 5 * math.pi / 180
    assert (out.run_dir / "passes.json").is_file() and (out.run_dir / "psi_tracking.png").is_file()
    ts = read_timeseries(out.run_dir)
    for key in (
        "t",
        "theta_rad",
        "phi_rad",
        "B_world_T",
        "q_wxyz",
        "omega_body_rad_s",
        "psi_ref_rad",
        "psi_dot_ref_rad_s",
        "psi_act_rad",
        "psi_dot_act_rad_s",
        "T_ref_body_Nm",
        "torque_body_Nm",
        "saturated",
        "err_rad",
    ):
        assert key in ts, key


def test_gravity_gradient_load_matches_body_axes_formula():
    cfg = load_config(TRACK100, ["gravity.gg_torque=true", "sim.duration_s=10"])
    sc = build_scenario(cfg)
    rng = np.random.default_rng(2)
    load = OrbitGravityGradientLoad(1, inertia_kgm2=sc.inertia, position=sc.orbit.position, mu=3.986004418e14)
    for _ in range(10):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        t = float(rng.uniform(0, 6000))
        st = StepState(
            t=t, pos=np.zeros((2, 3)), vel=np.zeros((2, 3)), xquat=np.array([[1.0, 0, 0, 0], q]), omega=np.zeros((2, 3))
        )
        R = quat_to_matrix(q)
        r = sc.orbit.position(t)
        rb = R.T @ r / np.linalg.norm(r)
        n2 = 3.986004418e14 / np.linalg.norm(r) ** 3
        T_b = 3 * n2 * np.cross(rb, sc.inertia * rb)
        assert np.allclose(R.T @ load.torque_world(st), T_b, rtol=1e-9, atol=1e-12)


def test_b3_cap_sweep_runs_the_grid_and_reports_the_minimum_caps(tmp_path):
    cfg = load_config(
        REPO / "magsail_mj" / "concepts" / "reflector" / "configs" / "pitch" / "b3_caps_sigma10.toml",
        ["sim.duration_s=40", "sim.progress=false"],
    )
    out = run_scenario(cfg, tmp_path / "run")
    s = json.loads((out.run_dir / "summary.json").read_text())
    assert s["runs"] == 17  # 0.25·2^(k/2), k = 0…16; the smallest passes
    assert s["cap_min_err_below_5deg_Nm"] == pytest.approx(0.25)
    assert s["cap_min_err_below_1deg_Nm"] == pytest.approx(0.25)
    assert (out.run_dir / "caps.png").is_file()


def test_cap_sweep_watchdog_stops_a_failing_run():
    assert cap_grid()[[0, -1]].tolist() == [0.25, 64.0]
    cfg = load_config(TRACK100, ["sim.duration_s=600", "sim.progress=false"])
    runner = CapSweepRunner(build_scenario(cfg).plate)
    r = runner._one(1.125, 0.01)  # 0.01° cannot be held: stopped early
    assert not r.passed and r.t_stop_s < 600 and r.err_max_rad > 0.01 * math.pi / 180


@pytest.mark.parametrize(
    "path, cls",
    [("detumble.toml", DetumbleTask), ("tracking_100g.toml", PitchTask), ("pitch/b3_caps_sigma10.toml", PitchCapsTask)],
)
def test_every_kind_builds_its_registered_task_class(path, cls):
    """One task class per ``kind``, registered under ``("reflector", kind)`` and found by build_scenario."""
    cfg = load_config(REPO / "magsail_mj" / "concepts" / "reflector" / "configs" / path, ["sim.duration_s=10"])
    assert TASKS[("reflector", cfg.kind)] is cls
    task = build_scenario(cfg)
    assert type(task) is cls and task.plate.cfg is cfg
