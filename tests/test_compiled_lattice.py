"""The lattice's compiled parts: the C RK4 reference (``magsail_mj.reference.compiled_rk4``) equals
the NumPy reference, and the strut forces of the ``magsail.lattice_springs`` MuJoCo plugin
(``magsail_mj.lattice.compiled_springs``) give the trajectories of the model with one tendon per
strut.

Tolerances (each test states its own): both comparisons are of the same equations summed in a
different order, so they differ by rounding. One rounding of a node coordinate of the 100 m
lattice is ~50 m × 1.1e-16 ≈ 6e-15 m; summed over 300–400 steps that is ≤ 3e-12 m. We assert
1e-11 m (positions) and 1e-11 m/s (velocities); measured: 4e-14 m and 7e-14 m/s (C against
NumPy, Case A, 300 steps), 3e-15 m and 1e-14 m/s (plugin against tendons). Each test also
checks that the nodes move by more than 1e-6 m, five orders of magnitude above the tolerance, so
that the comparison is of a run that does something.
"""

from __future__ import annotations

from pathlib import Path

import magsail_mj
import mujoco
import numpy as np
import pytest

from magsail_mj.config import load_config
from magsail_mj.lattice.compiled_springs import plugin_truss_model, strut_table
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec
from magsail_mj.lattice.properties import clamped_nodes, node_masses, strut_damping, strut_stiffness
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.reference.compiled_rk4 import CompiledLattice, StrutCouples
from magsail_mj.reference.numpy_rk4 import SpringMassLattice, from_truss_scenario, rk4_run
from tests.conftest import load_file_module

CASE_A = (
    Path(__file__).resolve().parents[1]
    / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_distributed_bangbang.toml"
)
POS_TOL_M = 1e-11
VEL_TOL_M_S = 1e-11
MOVES_M = 1e-6


@pytest.fixture(scope="module")
def case_a():
    """The Case A simulation (800 nodes, RK4 at 0.1 s) with its bang-bang-off over 30 s."""
    cfg = load_config(
        CASE_A, ["sim.integrator='RK4'", "sim.timestep_s=0.1", "sim.progress=false", "profile.t_end_s=30"]
    )
    return magsail_mj.load(cfg)


def profile_command(profile):
    """The benchmark's ``τ(t)`` of the scenario's ``[profile]`` table (the script's own function)."""
    return load_file_module("scripts", "bench_lattice_compiled", register=True).profile_command(profile)


def small_lattice(*, clamp: bool):
    """(lattice, masses, k, γ, clamped nodes) of a 3 × 3-cube, 10 m lattice with ζ_s = 0.1."""
    lat = make_lattice(units=3, side_m=10.0, diagonals="parity")
    k, _ = strut_stiffness(lat, EI_Nm2=100.0)
    m = node_masses(lat, total_kg=2.0)
    gamma = strut_damping(lat, k, zeta=0.1, particle_mass_kg=2.0 / lat.n_nodes)
    fixed = clamped_nodes(lat) if clamp else np.zeros(0, dtype=int)
    return lat, m, k, gamma, np.asarray(fixed, dtype=int)


def test_compiled_reference_equals_numpy_reference_with_the_distributed_torque(case_a):
    """Case A, 300 RK4 steps of 0.1 s; the bang-bang-off (0.1 N m over 30 s) switches sign at 10 s
    and ends at 20 s, so the load is on, reversed and off during the run; the records every 7 steps
    too (module docstring: tolerances)."""
    sc = case_a.scenario
    system, external, x0, v0 = from_truss_scenario(sc)
    compiled = CompiledLattice(system, couples=StrutCouples.from_load(sc.torque_load, profile_command(sc.cfg.profile)))
    xa, va, ra = rk4_run(system, x0, v0, dt=0.1, duration=30.0, external=external, record_every=7)
    xb, vb, rb = compiled.run(x0, v0, dt=0.1, n_steps=300, record_every=7)
    assert np.max(np.abs(xa - x0)) > MOVES_M
    assert np.max(np.abs(xb - xa)) < POS_TOL_M
    assert np.max(np.abs(vb - va)) < VEL_TOL_M_S
    np.testing.assert_array_equal(rb["t"], ra["t"])
    assert np.max(np.abs(rb["x"] - ra["x"])) < POS_TOL_M


def test_compiled_reference_clamped_springs_alone():
    """A 32-node lattice with one edge clamped, random deformation and velocities, no load, 400 RK4
    steps of 0.01 s: equal to the NumPy reference, and the clamped nodes never move."""
    lat, m, k, gamma, fixed = small_lattice(clamp=True)
    system = SpringMassLattice(masses=m, struts=lat.struts, k=k, l0=lat.rest_length, gamma=gamma, fixed=fixed)
    rng = np.random.default_rng(3)
    x0 = lat.nodes + 0.05 * rng.standard_normal(lat.nodes.shape)
    v0 = 0.1 * rng.standard_normal(lat.nodes.shape)
    x0[fixed], v0[fixed] = lat.nodes[fixed], 0.0
    xa, va, _ = rk4_run(system, x0, v0, dt=0.01, duration=4.0)
    xb, vb, _ = CompiledLattice(system).run(x0, v0, dt=0.01, n_steps=400)
    assert np.max(np.abs(xa - x0)) > MOVES_M
    assert np.max(np.abs(xb - xa)) < POS_TOL_M
    assert np.max(np.abs(vb - va)) < VEL_TOL_M_S
    np.testing.assert_array_equal(xb[fixed], x0[fixed])


def test_compiled_reference_refuses_the_best_fit_axis():
    lat, *_ = small_lattice(clamp=False)
    struts = lat.struts_of_kind("y_edge", layer=1)
    load = StrutTorqueLoad(lat, struts, command=lambda s: np.zeros(3), torque_axis="bestfit")
    with pytest.raises(ValueError, match="torque_axis"):
        StrutCouples.from_load(load, lambda t: np.zeros((t.size, 3)))


def _run_pair(model_a, model_b, qpos0, qvel0, n_steps):
    """Final (qpos, qvel) of both models after ``n_steps`` mj_steps from the same state."""
    out = []
    for model in (model_a, model_b):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = qpos0, qvel0
        for _ in range(n_steps):
            mujoco.mj_step(model, data)
        out.append((data.qpos.copy(), data.qvel.copy()))
    return out


def test_plugin_springs_give_the_tendon_trajectories_case_a(case_a):
    """Case A's model (3 402 tendons) against the plugin model without tendons: 300 RK4 steps of
    0.1 s from a random deformation (1 cm) and random node velocities (1 mm/s)."""
    tm, model = case_a.scenario.tm, case_a.model
    plugin = plugin_truss_model(
        tm.lattice, masses=tm.masses, stiffness=tm.k, damping=tm.gamma, options=TrussModelOptions(timestep_s=0.1)
    )
    assert plugin.ntendon == 0 and plugin.nplugin == 1 and plugin.nv == model.nv
    np.testing.assert_array_equal(plugin.body_mass, model.body_mass)
    rng = np.random.default_rng(5)
    qpos0 = 0.01 * rng.standard_normal(model.nq)
    qvel0 = 1e-3 * rng.standard_normal(model.nv)
    (qa, va), (qb, vb) = _run_pair(model, plugin, qpos0, qvel0, 300)
    assert np.max(np.abs(qa - qpos0)) > MOVES_M
    assert np.max(np.abs(qb - qa)) < POS_TOL_M
    assert np.max(np.abs(vb - va)) < VEL_TOL_M_S


def test_plugin_springs_with_clamped_nodes():
    """The small lattice with one edge clamped (nodes without dofs): 400 RK4 steps of 0.01 s."""
    lat, m, k, gamma, fixed = small_lattice(clamp=True)
    options = TrussModelOptions(timestep_s=0.01, fixed_nodes=tuple(int(i) for i in fixed))
    tendons = build_truss_spec(lat, masses=m, stiffness=k, damping=gamma, options=options).compile()
    plugin = plugin_truss_model(lat, masses=m, stiffness=k, damping=gamma, options=options)
    rng = np.random.default_rng(7)
    qpos0 = 0.05 * rng.standard_normal(tendons.nq)
    qvel0 = 0.1 * rng.standard_normal(tendons.nv)
    (qa, va), (qb, vb) = _run_pair(tendons, plugin, qpos0, qvel0, 400)
    assert np.max(np.abs(qa - qpos0)) > MOVES_M
    assert np.max(np.abs(qb - qa)) < POS_TOL_M
    assert np.max(np.abs(vb - va)) < VEL_TOL_M_S


def test_strut_table_names_a_bad_stiffness():
    lat, m, k, gamma, _ = small_lattice(clamp=False)
    model = build_truss_spec(lat, masses=m, stiffness=k, damping=gamma).compile()
    with pytest.raises(ValueError, match="stiffness"):
        strut_table(model, lat, stiffness=k[:-1], damping=gamma)
