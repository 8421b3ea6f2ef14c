"""Truss distributed-vs-centralised keys (delivered impulse, central strut tilt, σ_SD trend after
the torque is off, Fig. 9 ratios), the initial-state perturbation, the artefact-free cell
surface angles and the slews' dipole effort integral.

Every check compares against an analytic value, an invariant or an independent computation:

* delivered impulse: on a short, small run the best-fit body x1 impulse of the applied couples
  equals the commanded ``τ_max t`` (the lattice barely turns in 20 s: 1e-5 relative), and the
  world impulse equals the change of the particles' angular momentum ``Σ m (x − x_c) × v``
  (internal strut forces are central and cancel; RK4 leaves 1e-6 relative);
* strut tilt: a rigid rotation gives 0, a strut turned by a known angle gives that angle;
* σ_SD trend: a synthetic ``a + b t + A sin(2π t/P)`` after the cut-off returns ``b``, ``A``, ``P``;
* cell angles: a tilted plane gives 0 (it is its own average plane), a paraboloid and a twist
  give the analytic angle at every cell centre to round-off.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import magsail_mj
from magsail_mj.config import load_config
from magsail_mj.concepts.truss_magnetorquer.config import ProfileConfig
from magsail_mj.concepts.truss_magnetorquer.metrics import (
    commanded_impulse_Nms,
    placement_ratios,
    profile_response,
    strut_tilt_rad,
)
from magsail_mj.concepts.truss_magnetorquer.surface_angle import cell_surface_angle, local_surface_angle
from magsail_mj.concepts.truss_magnetorquer.tasks import perturbed_positions
from magsail_mj.export import read_timeseries
from tests.conftest import REPO

CONFIGS = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central"
SMALL = ["lattice.units=3", "sim.duration_s=20", "sim.record_every=10"]


def _angular_momentum(sim) -> np.ndarray:
    """Σ m (x − x_c) × v of the particles [N m s] (world), from the final MuJoCo state."""
    tm = sim.scenario.tm
    p = tm.lattice.nodes
    x = p + sim.data.qpos.reshape(-1, 3)
    v = sim.data.qvel.reshape(-1, 3)
    xc = np.average(x, axis=0, weights=tm.masses)
    return np.sum(tm.masses[:, None] * np.cross(x - xc, v), axis=0)


@pytest.mark.parametrize("placement", ["central", "distributed"])
def test_delivered_impulse_matches_command_and_momentum(placement):
    """20 s of +τ_max about x1 on a 3 × 3-cube Case A lattice: commanded 0.1 N m × 20 s = 2 N m s
    (the left-rectangle sum is exact for the constant plateau); delivered body x1 within 1e-5
    (the lattice turns by ~1e-4 rad); world impulse = ΔH within 1e-6 relative."""
    sim = magsail_mj.load(CONFIGS / f"case_a_{placement}_bangbang.toml", SMALL)
    result = sim.run()
    summary, series = sim.scenario.postprocess(result)
    assert summary["impulse_x1_commanded_Nms"] == pytest.approx(2.0, rel=1e-12)
    assert summary["impulse_x1_delivered_Nms"] == pytest.approx(2.0, rel=1e-5)
    assert summary["impulse_x1_delivered_ratio_t_minus"] == pytest.approx(1.0, abs=1e-5)
    assert summary["impulse_cross_peak_delivered_Nms"] < 1e-5 * 2.0
    world = result.records["impulse_ac_world_Nms"][-1]
    np.testing.assert_allclose(world, _angular_momentum(sim), rtol=0, atol=1e-6 * 2.0)
    assert series["central_strut_tilt_rad"].shape == result.records["t"].shape


def test_commanded_impulse_of_the_bang_bang_profile():
    """Bang-bang-off, t_end = 1800 s: I(600) = 60 N m s, I(1200) = 0, I(1800) = 0 (rest to rest),
    up to one step of τ_max per breakpoint passed (the profile is closed at t_− and t_0, so the
    step starting there still holds the earlier sign): 2 τ_max δt = 0.02 N m s."""
    p = ProfileConfig(kind="bang_bang_off", tau_max_Nm=0.1, t_end_s=1800.0)
    t = np.array([0.0, 300.0, 600.0, 900.0, 1200.0, 1800.0])
    cmd = commanded_impulse_Nms(p, t, timestep_s=0.1)
    np.testing.assert_allclose(cmd, [0.0, 30.0, 60.0, 30.0, 0.0, 0.0], atol=2 * 0.1 * 0.1 + 1e-9)


def test_commanded_impulse_follows_the_load_timing():
    """Versine profile (smooth): with the torque evaluated at each step's mid-point the commanded
    impulse is the mid-point rule, second order in δt (halving δt divides the error from the exact
    integral by 4), where the left-rectangle sum of start-of-step torques is first order."""
    p = ProfileConfig(kind="versine", tau_max_Nm=0.1, t_end_s=1800.0, t_v_s=180.0)
    t = np.array([150.0, 700.0])
    fine = commanded_impulse_Nms(p, t, timestep_s=1e-3, load_timing="midpoint")

    def errors(timing: str) -> list[float]:
        return [
            float(np.max(np.abs(commanded_impulse_Nms(p, t, timestep_s=dt, load_timing=timing) - fine)))
            for dt in (0.2, 0.1)
        ]

    start, mid = errors("start"), errors("midpoint")
    assert start[0] / start[1] == pytest.approx(2.0, rel=0.05)
    assert mid[0] / mid[1] == pytest.approx(4.0, rel=0.05)
    assert mid[1] < 1e-3 * start[1]


def test_strut_tilt_rigid_rotation_and_known_bend():
    """Two struts; all nodes rotated rigidly by 30° about z: tilt 0 (the best-fit frame follows).
    Then one strut end moved so that strut turns by 5° in the body frame: tilt 5°."""
    nodes = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    ends = np.array([[0, 1], [2, 3]])
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    rigid = nodes @ R.T
    bent_body = nodes.copy()
    beta = math.radians(5.0)
    bent_body[3] = nodes[2] + np.array([0.0, math.cos(beta), math.sin(beta)])
    pos = np.stack([rigid, bent_body @ R.T])
    tilt = strut_tilt_rad(pos, np.stack([R, R]), nodes=nodes, ends=ends)
    assert tilt[0] == pytest.approx(0.0, abs=1e-12)
    assert tilt[1] == pytest.approx(beta, rel=1e-12)


def test_sd_trend_after_cut_off_of_a_synthetic_signal():
    """σ_SD = 0.3 + b t + A cos(2π t / P) after t_0 = 1200 s (b = 1e-5 m/s, A = 0.02 m, P = 150 s,
    window L = 600 s = 4 periods): slope b (5 %; a cosine over whole periods does not bias the
    continuous least-squares slope, the 600 samples t = 1201 … 1800 s leave 3.3 %), amplitude A
    (2 %), period P (2 %). With a sine instead the slope is
    biased by −6 A P/(π L²) = −1.59e-5 m/s (∫(t − L/2) sin(2π t/P) dt = −L P/(2π) over whole
    periods): checked to 5 %, a reminder that the slope of a short window carries the oscillation."""
    p = ProfileConfig(kind="bang_bang_off", tau_max_Nm=0.1, t_end_s=1800.0)
    t = np.arange(0.0, 1800.0 + 1e-9, 1.0)
    b, A, P, L = 1e-5, 0.02, 150.0, 600.0
    zeros = np.zeros((t.size, 3))
    keys, _ = profile_response(
        p, t, 0.3 + b * t + A * np.cos(2 * np.pi * t / P), inertia_kgm2=1.0, torque_cmd_body_Nm=zeros
    )
    assert keys["surface_sd_after_off_slope_m_s"] == pytest.approx(b, rel=0.05)
    assert keys["surface_sd_after_off_osc_amplitude_m"] == pytest.approx(A, rel=0.02)
    assert keys["surface_sd_after_off_period_s"] == pytest.approx(P, rel=0.02)
    keys, _ = profile_response(
        p, t, 0.3 + b * t + A * np.sin(2 * np.pi * t / P), inertia_kgm2=1.0, torque_cmd_body_Nm=zeros
    )
    assert keys["surface_sd_after_off_slope_m_s"] == pytest.approx(b - 6 * A * P / (np.pi * L**2), rel=0.05)


def test_placement_ratios_and_failed_runs():
    central = {"surface_angle_median_rad": 0.02, "surface_angle_cell_median_rad": 0.01, "surface_sd_max_m": 3.0}
    dist = {"surface_angle_median_rad": 0.01, "surface_angle_cell_median_rad": 0.004, "surface_sd_max_m": 1.0}
    r = placement_ratios(central, dist)
    assert r["surface_angle_median_ratio_central_to_distributed"] == pytest.approx(2.0)
    assert r["surface_angle_cell_median_ratio_central_to_distributed"] == pytest.approx(2.5)
    assert r["surface_sd_max_ratio_central_to_distributed"] == pytest.approx(3.0)
    failed = placement_ratios({**central, "failed": True}, dist)
    assert all(math.isnan(v) for v in failed.values())


def _grid(N: int, h: float, w) -> np.ndarray:
    """(N², 3) j-major grid nodes (u = i h, v = j h, centred) with heights ``w(u, v)``."""
    a = (np.arange(N) - (N - 1) / 2) * h
    U, V = np.meshgrid(a, a)  # [j, i]
    return np.stack([U.ravel(), V.ravel(), w(U, V).ravel()], axis=1)


def test_cell_angles_of_a_tilted_plane_are_zero():
    """A plane tilted by 20° about y: it is its own average plane, so every cell angle is 0."""
    x = _grid(6, 1.0, lambda u, v: math.tan(math.radians(20.0)) * u)
    cell = cell_surface_angle(x, np.eye(3), nodes_per_side=6)
    assert cell.max == pytest.approx(0.0, abs=1e-12)
    assert cell.edge_max == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("shape", ["paraboloid", "twist"])
def test_cell_angles_are_exact_at_cell_centres_for_quadratics(shape):
    """w = κ (u² + v²)/2 (tan α = κ r) or w = κ u v (tan α = κ √(u² + v²)), symmetric grid (its
    average plane is w = const): every cell angle equals the analytic angle at its centre to 1e-12;
    the edge maximum is the corner cell's. The fitted ``cubic`` map's edge maximum is reported by
    the docs for comparison, not asserted."""
    N, h, kappa = 8, 1.0, 0.02
    w = (lambda u, v: 0.5 * kappa * (u * u + v * v)) if shape == "paraboloid" else (lambda u, v: kappa * u * v)
    x = _grid(N, h, w)
    cell = cell_surface_angle(x, np.eye(3), nodes_per_side=N)
    c = (np.arange(N - 1) - (N - 2) / 2) * h
    Uc, Vc = np.meshgrid(c, c)
    exact = np.arctan(kappa * np.hypot(Uc, Vc))
    np.testing.assert_allclose(cell.alpha, exact, rtol=1e-12, atol=1e-15)
    assert cell.edge_max == pytest.approx(float(exact.max()), rel=1e-12)
    assert cell.median == pytest.approx(float(np.median(exact)), rel=1e-12)
    assert np.isfinite(local_surface_angle(x, np.eye(3)).edge_max)


def test_perturbation_keeps_the_centre_of_mass_and_is_seeded():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(20, 3))
    m = rng.uniform(1.0, 2.0, size=20)
    a, rms_a = perturbed_positions(x, m, sigma_m=0.01, seed=3)
    b, _ = perturbed_positions(x, m, sigma_m=0.01, seed=3)
    c, _ = perturbed_positions(x, m, sigma_m=0.01, seed=4)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    np.testing.assert_allclose(np.average(a, axis=0, weights=m), np.average(x, axis=0, weights=m), atol=1e-15)
    assert 0.005 < rms_a < 0.03


def test_perturbed_run_starts_displaced_and_records_it():
    """σ = 0.01 m: the initial qpos is non-zero with the RMS the manifest states; default σ = 0
    leaves the rigid start exactly (qpos = 0 for the identity attitude)."""
    sets = [*SMALL, "sim.duration_s=1"]
    sim0 = magsail_mj.load(CONFIGS / "case_b_central_bangbang.toml", sets)
    sim0.reset()
    assert not np.any(sim0.data.qpos)
    assert sim0.scenario.manifest_extra()["initial_perturbation"]["rms_displacement_m"] == 0.0
    sim = magsail_mj.load(
        CONFIGS / "case_b_central_bangbang.toml",
        [*sets, "initial.node_perturbation_m=0.01", "initial.perturbation_seed=7"],
    )
    sim.reset()
    rms = float(np.sqrt(np.mean(np.sum(sim.data.qpos.reshape(-1, 3) ** 2, axis=1))))
    entry = sim.scenario.manifest_extra()["initial_perturbation"]
    assert entry["seed"] == 7 and entry["node_perturbation_m"] == 0.01
    assert rms == pytest.approx(entry["rms_displacement_m"], rel=1e-12)
    assert 0.005 < rms < 0.03


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        ("-0.01", "node_perturbation_m"),
        ("nan", "node_perturbation_m"),
        ("inf", "node_perturbation_m"),
        ("1.0", "node_perturbation_m"),
    ],
)
def test_hostile_perturbations_are_refused_naming_the_key(value, fragment):
    """Negative, NaN, infinite, or ≥ 5 % of a cube edge (100 m / 19 cubes: 0.263 m) are refused."""
    with pytest.raises(ValueError, match=fragment):
        load_config(CONFIGS / "case_b_central_bangbang.toml", [f"initial.node_perturbation_m={value}"])


def test_negative_seed_is_refused():
    with pytest.raises(ValueError, match="perturbation_seed"):
        load_config(CONFIGS / "case_b_central_bangbang.toml", ["initial.perturbation_seed=-1"])


def test_slew_dipole_effort_integral():
    """``int_dipole_abs_Am2s`` = ∫ (|N1| m₁ + |N2| m₂) dt; both families carry the same rod dipole
    here, so it equals m_rod ∫ (|N1| + |N2|) dt (the count integral, summed separately) to 1e-12."""
    sim = magsail_mj.load(
        REPO / "magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml",
        ["lattice.units=3", "sim.duration_s=3", "control.cache_dir=''"],
    )
    summary, _ = sim.scenario.postprocess(sim.run())
    m1, m2 = summary["rod_dipole_Am2"]
    assert m1 == m2
    assert summary["int_N_abs_s"] > 0
    assert summary["int_dipole_abs_Am2s"] == pytest.approx(m1 * summary["int_N_abs_s"], rel=1e-12)
    assert summary["int_dipole_abs_first_3600s_Am2s"] == summary["int_dipole_abs_Am2s"]


@pytest.mark.slow
def test_stop_and_resume_keeps_the_impulse_meter(tmp_path):
    """The meter's running impulse is part of the run's state: a run stopped at 10 s and resumed
    gives the same records, bit for bit, as an uninterrupted one."""
    config = str(CONFIGS / "case_a_central_bangbang.toml")

    def magsail(*args):
        cmd = [sys.executable, "-m", "magsail_mj.entry", "run", config, "--no-progress"]
        sets = [x for s in SMALL for x in ("--set", s)]
        return subprocess.run([*cmd, *sets, *args], capture_output=True, text=True, cwd=tmp_path, timeout=300)

    assert magsail("--out", str(tmp_path / "full")).returncode == 0
    assert magsail("--out", str(tmp_path / "cut"), "--stop-after-s", "10").returncode == 0
    resumed = magsail("--out", str(tmp_path / "cut"), "--resume")
    assert resumed.returncode == 0, resumed.stderr
    a, b = read_timeseries(tmp_path / "full"), read_timeseries(tmp_path / "cut")
    assert np.any(a["impulse_ac_body_Nms"])
    assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in ("impulse_ac_body_Nms", "impulse_ac_world_Nms"))
