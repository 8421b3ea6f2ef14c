"""Physics of the MuJoCo lattice model (Robb et al. 2022a, Sec. 2: spring–dashpot struts, strut
torquers, cantilever check; RK4 replacement within our tolerances).

The model is the real one (``magsail_mj.lattice.mjcf.build_truss_spec``, or a scenario built from
a config), on small lattices so that the default run stays fast. Momentum and energy are
computed here from ``qpos``/``qvel`` and the node positions, independently of the model code.

Tolerances reached (and asserted with margin, see each test):
- linear momentum, free lattice, no load, γ = 0, 100 s: ~1e-14 relative (rounding), RK4 and Euler;
- angular momentum: Euler (symplectic Euler, exact for central forces) ~1e-14 relative;
  RK4 at δt = 0.005 s ~1e-9 relative over 100 s (its O(δt⁴) truncation error);
- energy, RK4 at δt = 0.005 s (ω_max δt = 0.036), γ = 0, 100 s: relative drift 1.6e-7;
- with ζ_s = 0.1 the energy falls at every one of 6000 RK4 steps (largest step change −2.5e-10 E0).
"""

from __future__ import annotations

from pathlib import Path

import magsail_mj  # noqa: F401  (picks the GL backend before mujoco is imported)
import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.analysis.flatness import surface_sd
from magsail_mj.config import apply_overrides, load_config, parse_config
from magsail_mj.estimation.attitude import best_fit_rotation, particle_inertia, rotation_angle
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.properties import (
    cantilever_linear,
    clamped_nodes,
    node_masses,
    strut_damping,
    strut_stiffness,
)
from magsail_mj.loads.base import StepState
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec, node_positions_from_qpos
from magsail_mj.reference.numpy_rk4 import SpringMassLattice, from_truss_scenario, rk4_run
from magsail_mj.concepts.truss_magnetorquer.model import actuated_struts
from magsail_mj.concepts.truss_magnetorquer.tasks import build_truss_scenario
from magsail_mj.sim import Simulation

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"


def small_model(
    *,
    units=2,
    side=10.0,
    EI=100.0,
    total=2.0,
    diagonals="parity",
    gamma=0.0,
    integrator="RK4",
    dt=0.01,
    fixed=(),
    k=None,
):
    """(lattice, masses, k, compiled model) of a small free (or clamped) lattice."""
    lat = make_lattice(units=units, side_m=side, diagonals=diagonals)
    if k is None:
        k, _ = strut_stiffness(lat, EI_Nm2=EI)
    m = node_masses(lat, total_kg=total)
    spec = build_truss_spec(
        lat,
        masses=m,
        stiffness=k,
        damping=gamma,
        options=TrussModelOptions(timestep_s=dt, integrator=integrator, fixed_nodes=tuple(fixed)),
    )
    return lat, m, k, spec.compile()


def strut_law_forces(x, v, struts, k, l0, gamma):
    """The spring–dashpot strut law written out with np.add.at (independent of the model and the reference)."""
    i, j = struts[:, 0], struts[:, 1]
    r = x[j] - x[i]
    ell = np.linalg.norm(r, axis=1)
    rh = r / ell[:, None]
    rdot = v[j] - v[i]
    F = (k * (ell - l0))[:, None] * rh + (gamma * np.sum(rdot * rh, axis=1))[:, None] * rh
    out = np.zeros_like(x)
    np.add.at(out, i, F)
    np.add.at(out, j, -F)
    return out


def momentum(m, x, v):
    """Linear Σ m v and angular Σ m x × v (about the world origin)."""
    return (m[:, None] * v).sum(axis=0), (m[:, None] * np.cross(x, v)).sum(axis=0)


def energies(lat, m, k, model, data):
    """(kinetic, strain) energy [J] from qpos/qvel of a free lattice."""
    x = node_positions_from_qpos(model, data.qpos, n_nodes=lat.n_nodes)
    r = x[lat.struts[:, 1]] - x[lat.struts[:, 0]]
    strain = 0.5 * np.sum(k * (np.linalg.norm(r, axis=1) - lat.rest_length) ** 2)
    v = data.qvel.reshape(-1, 3)
    return 0.5 * np.sum(m * np.sum(v * v, axis=1)), strain


def randomise(model, data, lat, rng, *, dx=0.05, dv=0.1):
    """Random deformation (dx · a per coordinate) and random velocities (dv m/s)."""
    data.qpos[:] = rng.normal(size=model.nq) * dx * lat.cube_edge_m
    data.qvel[:] = rng.normal(size=model.nv) * dv


# ------------------------------------------------------------------------------ strut law


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), diagonals=st.sampled_from(["parity", "X"]), clamp=st.booleans())
def test_tendon_force_is_the_spec_strut_law(seed, diagonals, clamp):
    """qfrc_passive = Σ k(r−l0)r̂ + γ(ṙ·r̂)r̂ (the strut law) at a random deformed, moving state.

    Random per-strut k and γ, deformation up to ~20 % of a, random velocities; optionally the
    i = 0 edge clamped (no joints). Agreement to 1e-10 of the largest force component (measured
    ~1e-15: both sides are the same few flops per strut).
    """
    rng = np.random.default_rng(seed)
    lat = make_lattice(units=2, side_m=float(rng.uniform(1, 50)), diagonals=diagonals)
    k = rng.uniform(0.1, 10.0, lat.n_struts)
    gamma = rng.uniform(0.0, 1.0, lat.n_struts)
    m = rng.uniform(0.1, 2.0, lat.n_nodes)
    fixed = clamped_nodes(lat) if clamp else np.zeros(0, int)
    spec = build_truss_spec(
        lat, masses=m, stiffness=k, damping=gamma, options=TrussModelOptions(fixed_nodes=tuple(fixed))
    )
    model = spec.compile()
    data = mujoco.MjData(model)
    randomise(model, data, lat, rng, dx=0.07, dv=0.5)
    mujoco.mj_forward(model, data)
    free = np.setdiff1d(np.arange(lat.n_nodes), fixed)
    x = node_positions_from_qpos(model, data.qpos, n_nodes=lat.n_nodes)
    v = np.zeros_like(x)
    v[free] = data.qvel.reshape(-1, 3)
    F = strut_law_forces(x, v, lat.struts, k, lat.rest_length, gamma)
    scale = np.abs(F).max()
    np.testing.assert_allclose(data.qfrc_passive.reshape(-1, 3), F[free], rtol=0, atol=1e-10 * scale)
    # the NumPy reference evaluates the same law
    ref = SpringMassLattice(masses=m, struts=lat.struts, k=k, l0=lat.rest_length, gamma=gamma)
    np.testing.assert_allclose(ref.forces(x, v), F, rtol=0, atol=1e-10 * scale)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_dashpot_power_is_never_positive(seed):
    """The damper force only dissipates: qfrc_damper · qvel = −Σ γ (ṙ·r̂)² ≤ 0."""
    rng = np.random.default_rng(seed)
    lat, m, k, model = small_model(gamma=float(rng.uniform(0.01, 1.0)))
    data = mujoco.MjData(model)
    randomise(model, data, lat, rng, dx=0.1, dv=1.0)
    mujoco.mj_forward(model, data)
    x = node_positions_from_qpos(model, data.qpos, n_nodes=lat.n_nodes)
    v = data.qvel.reshape(-1, 3)
    r = x[lat.struts[:, 1]] - x[lat.struts[:, 0]]
    rdot = np.sum((v[lat.struts[:, 1]] - v[lat.struts[:, 0]]) * r, axis=1) / np.linalg.norm(r, axis=1)
    gamma = model.tendon_damping[0]
    power = float(data.qfrc_damper @ data.qvel)
    np.testing.assert_allclose(power, -gamma * np.sum(rdot**2), rtol=1e-10)
    assert power <= 0.0


# ------------------------------------------------------------------------------ conservation


@pytest.mark.parametrize("integrator,dt,tol_L", [("Euler", 0.01, 1e-11), ("RK4", 0.005, 1e-7)])
def test_momentum_conserved_without_loads(integrator, dt, tol_L):
    """No loads, γ = 0: Σ m v and Σ m x × v stay constant (from qvel and node positions).

    Linear momentum: internal forces cancel pairwise, so both integrators keep it to rounding;
    asserted 1e-12 relative (measured 4e-15 Euler, 1e-14 RK4). Angular momentum: MuJoCo's Euler
    is symplectic Euler (v⁺ = v + h a(x), x⁺ = x + h v⁺), which conserves Σ m x × v exactly for
    central forces: asserted 1e-11 (measured 1.1e-14). RK4 conserves it only to its truncation
    error: asserted 1e-7 at δt = 0.005 s over 100 s (measured 1.0e-9).
    """
    lat, m, k, model = small_model(integrator=integrator, dt=dt)
    data = mujoco.MjData(model)
    randomise(model, data, lat, np.random.default_rng(3))
    data.qvel.reshape(-1, 3)[:] += np.cross([0.0, 0.0, 0.05], lat.nodes) + [0.02, -0.01, 0.03]  # spin + drift

    def P_L():
        x = node_positions_from_qpos(model, data.qpos, n_nodes=lat.n_nodes)
        return momentum(m, x, data.qvel.reshape(-1, 3))

    P0, L0 = P_L()
    scale_P = np.sum(m * np.linalg.norm(data.qvel.reshape(-1, 3), axis=1))
    dP = dL = 0.0
    for step in range(int(round(100.0 / dt))):
        mujoco.mj_step(model, data)
        if step % 50 == 0:
            P, L = P_L()
            dP = max(dP, np.abs(P - P0).max() / scale_P)
            dL = max(dL, np.abs(L - L0).max() / np.linalg.norm(L0))
    assert dP < 1e-12
    assert dL < tol_L


def test_energy_conserved_rk4_free_vibration():
    """γ = 0, RK4 at δt = 0.005 s: (kinetic + strain) relative drift < 1e-6 over 100 s.

    The 2 × 2-cube lattice has ω_max = 7.2 rad/s, so ω_max δt = 0.036; the vibration starts
    from a random 5 %-of-a deformation and random velocities (measured drift ~1.6e-7).
    """
    lat, m, k, model = small_model(integrator="RK4", dt=0.005)
    data = mujoco.MjData(model)
    randomise(model, data, lat, np.random.default_rng(0))
    E0 = sum(energies(lat, m, k, model, data))
    drift = 0.0
    for step in range(20000):
        mujoco.mj_step(model, data)
        if step % 20 == 0:
            drift = max(drift, abs(sum(energies(lat, m, k, model, data)) - E0) / E0)
    assert drift < 1e-6


def test_energy_never_increases_with_damping():
    """γ > 0 (ζ_s = 0.1), RK4 at δt = 0.01 s: E(t) is non-increasing, step by step.

    Allowed rise per step 1e-12 E0 (rounding of the energy sums); the energy must also really
    fall (the test fails for γ = 0 drift or for a sign error in the dashpot).
    """
    lat = make_lattice(units=2, side_m=10.0)
    k, _ = strut_stiffness(lat, EI_Nm2=100.0)
    gamma = strut_damping(lat, k, zeta=0.1, particle_mass_kg=2.0 / lat.n_nodes)
    lat, m, k, model = small_model(gamma=gamma, dt=0.01)
    data = mujoco.MjData(model)
    randomise(model, data, lat, np.random.default_rng(1))
    E = [sum(energies(lat, m, k, model, data))]
    for _ in range(6000):
        mujoco.mj_step(model, data)
        E.append(sum(energies(lat, m, k, model, data)))
    E = np.array(E)
    assert np.max(np.diff(E)) <= 1e-12 * E[0]
    assert E[-1] < 0.5 * E[0]


def test_discrete_integrator_is_stable_beyond_the_explicit_limit():
    """MuJoCo's ``discrete`` step (strut springs in the metric M + hD + h²K) at δt = 1 s,
    ω_max δt = 7.2 (the explicit bound is ω_max δt < 2): the energy never rises (backward Euler
    is dissipative: allowed rise per step 1e-9 E0, the solve's tolerance), it falls below 1 %
    of E0 within 200 steps, and Σ m v is kept to 1e-6 relative (internal forces cancel in the
    metric too, up to the iterative solve, which stops at a relative residual of 1e-8 per step:
    measured 5e-8 after 200 steps). Euler at the same step diverges, so the test tells the two apart.
    """
    for integrator in ("Euler", "discrete"):
        lat, m, k, model = small_model(integrator=integrator, dt=1.0)
        data = mujoco.MjData(model)
        randomise(model, data, lat, np.random.default_rng(5))
        P0 = (m[:, None] * data.qvel.reshape(-1, 3)).sum(axis=0)
        scale_P = np.sum(m * np.linalg.norm(data.qvel.reshape(-1, 3), axis=1))
        E = [sum(energies(lat, m, k, model, data))]
        for _ in range(200):
            mujoco.mj_step(model, data)
            E.append(sum(energies(lat, m, k, model, data)))
        E = np.array(E)
        if integrator == "Euler":
            assert not np.all(np.isfinite(E)) or E.max() > 1e3 * E[0]
            continue
        P = (m[:, None] * data.qvel.reshape(-1, 3)).sum(axis=0)
        assert np.max(np.diff(E)) <= 1e-9 * E[0]
        assert E[-1] < 0.01 * E[0]
        assert np.abs(P - P0).max() < 1e-6 * scale_P


def test_solver_tolerance_reaches_the_model(small_truss_tree):
    """``sim.integrator = "discrete"`` and ``sim.solver_tolerance`` end up in the compiled model."""
    tree = apply_overrides(small_truss_tree, ["sim.integrator='discrete'", "sim.solver_tolerance=1e-5"])
    sc = build_truss_scenario(parse_config(tree))
    assert sc.model.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE
    assert sc.model.opt.tolerance == pytest.approx(1e-5)


# ------------------------------------------------------------------------------ strut torquer


def _columns_normal(lat, pos, i, j):
    """Strut-torquer local normal (our choice) n = (r_i − r_i') + (r_j − r_j') (bottom node below each end)."""
    N2 = lat.nodes_per_side**2
    return (pos[i] - pos[i % N2]) + (pos[j] - pos[j % N2])


def test_strut_torquer_undeformed_couple():
    """Strut torquer: an undeformed y1-strut's couple is τ_s x̂1; the total is the command τ."""
    lat = make_lattice(units=5, side_m=20.0)
    y_top = lat.struts_of_kind("y_edge", layer=1)
    x_top = lat.struts_of_kind("x_edge", layer=1)
    pos = np.vstack([np.zeros(3), lat.nodes])  # node i is body i + 1
    state = StepState(
        t=0.0, pos=pos, vel=np.zeros_like(pos), xquat=np.zeros((pos.shape[0], 4)), omega=np.zeros_like(pos)
    )
    tau1 = 0.3
    load = StrutTorqueLoad(lat, y_top, command=lambda s: np.array([tau1, 0.0, 0.0]))
    xfrc = np.zeros((lat.n_nodes + 1, 6))
    load.add(state, xfrc)
    ends = lat.struts[y_top]
    r = lat.nodes[ends[:, 1]] - lat.nodes[ends[:, 0]]
    couple = np.cross(r, load.last_force_j)  # ℓ ê × F_j about the midpoint
    np.testing.assert_allclose(couple, np.tile([tau1 / y_top.size, 0, 0], (y_top.size, 1)), rtol=0, atol=1e-15 * tau1)
    np.testing.assert_allclose(xfrc[:, :3].sum(axis=0), 0.0, atol=1e-16)
    # total couple of both families for an arbitrary command (τ₂ from x1-struts, τ₃ from both)
    tau = np.array([0.3, -0.2, 0.05])
    both = np.concatenate([y_top, x_top])
    load = StrutTorqueLoad(lat, both, command=lambda s: tau)
    xfrc[:] = 0.0
    load.add(state, xfrc)
    np.testing.assert_allclose(np.cross(pos, xfrc[:, :3]).sum(axis=0), tau, rtol=0, atol=1e-14)
    np.testing.assert_allclose(xfrc[:, :3].sum(axis=0), 0.0, atol=1e-16)
    assert not np.any(xfrc[:, 3:])


@pytest.mark.parametrize("placement,pair", [("central", "top"), ("central", "diagonal"), ("distributed", "top")])
def test_scenario_actuators_make_the_commanded_couple(placement, pair):
    """Placements (Robb et al. 2022a, Fig. 3): distributed (380 top y1-struts) and central (2 struts)
    give couple τ x̂1."""
    cfg = load_config(MODELS / "dist_vs_central/case_a_central_bangbang.toml")
    cfg.actuators.placement = placement
    cfg.actuators.central_pair = pair
    lat = make_lattice(units=19, side_m=100.0)
    struts = actuated_struts(lat, cfg.actuators, "x1")
    assert struts.size == (380 if placement == "distributed" else 2)
    pos = np.vstack([np.zeros(3), lat.nodes])
    state = StepState(t=0.0, pos=pos, vel=np.zeros_like(pos), xquat=np.zeros((801, 4)), omega=np.zeros_like(pos))
    xfrc = np.zeros((801, 6))
    StrutTorqueLoad(lat, struts, command=lambda s: np.array([0.1, 0, 0])).add(state, xfrc)
    np.testing.assert_allclose(np.cross(pos, xfrc[:, :3]).sum(axis=0), [0.1, 0, 0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(xfrc[:, :3].sum(axis=0), 0.0, atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), amp=st.floats(0.0, 0.25))
def test_strut_torquer_on_deformed_lattice(seed, amp):
    """Random deformed lattice, random command: every strut's pair is a pure couple ⊥ its strut.

    Per strut: F_i = −F_j, F ⊥ ê (no axial part), couple ℓ ê × F_j ⊥ ê with components
    a_s about ê × n̂⊥ and c_s about n̂⊥ (n̂⊥ from the local columns, computed here), i.e. the
    commanded strut torques. Summed: zero net force, so the moment is the same about any point.
    Tolerances 1e-12 relative (rounding of a few vector products).
    """
    rng = np.random.default_rng(seed)
    lat = make_lattice(units=3, side_m=float(rng.uniform(1, 100)))
    a = lat.cube_edge_m
    x = lat.nodes + rng.normal(size=lat.nodes.shape) * amp * a
    pos = np.vstack([np.zeros(3), x])
    struts = np.concatenate([lat.struts_of_kind("y_edge", layer=1), lat.struts_of_kind("x_edge", layer=1)])
    tau = rng.normal(size=3)
    load = StrutTorqueLoad(lat, struts, command=lambda s: tau)
    xfrc = np.zeros((lat.n_nodes + 1, 6))
    state = StepState(
        t=0.0, pos=pos, vel=np.zeros_like(pos), xquat=np.zeros((pos.shape[0], 4)), omega=np.zeros_like(pos)
    )
    load.add(state, xfrc)
    F = load.last_force_j
    i, j = lat.struts[struts, 0], lat.struts[struts, 1]
    r = x[j] - x[i]
    e = r / np.linalg.norm(r, axis=1)[:, None]
    n = _columns_normal(lat, x, i, j)
    n_perp = n - np.sum(n * e, axis=1)[:, None] * e
    n_hat = n_perp / np.linalg.norm(n_perp, axis=1)[:, None]
    a_s, c_s = load.strut_torques(tau)
    Fmag = np.linalg.norm(F, axis=1)
    scale = np.abs(tau).max()
    np.testing.assert_allclose(np.sum(F * e, axis=1), 0.0, atol=1e-12 * Fmag.max())
    couple = np.cross(r, F)
    np.testing.assert_allclose(np.sum(couple * e, axis=1), 0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(np.sum(couple * np.cross(e, n_hat), axis=1), a_s, atol=1e-12 * scale)
    np.testing.assert_allclose(np.sum(couple * n_hat, axis=1), c_s, atol=1e-12 * scale)
    np.testing.assert_allclose(xfrc[:, :3].sum(axis=0), 0.0, atol=1e-12 * Fmag.sum())
    p = rng.normal(size=3) * 10
    M0 = np.cross(pos, xfrc[:, :3]).sum(axis=0)
    Mp = np.cross(pos - p, xfrc[:, :3]).sum(axis=0)
    np.testing.assert_allclose(Mp, M0, atol=1e-12 * scale * max(1.0, np.abs(p).max() / a))
    assert not np.any(xfrc[0]), "no force on the world body"


def test_stiff_lattice_under_distributed_torque_accelerates_at_T_over_I():
    """A stiff free lattice under a constant distributed torque T about x1 (the strut torquers): the
    best-fit angle follows ½ (T/I₁) t² within 2 % (I₁ from Eq. 21), Σ m (x × v)_x = T t within
    2 %, and the load's net force is zero to rounding at every recorded step (so the centre of
    mass stays at rest: |Σ m v| < 1e-12 T t / a).

    3 × 3 cubes, 12 m, 8 kg, EI = 1e3 N m² (ω_max ≈ 16 rad/s; RK4 at 0.02 s), T = 0.01 N m,
    40 s (φ ≈ 0.042 rad). Measured: α/(T/I₁) − 1 ≈ −9e-8, L_x/(T t) − 1 ≈ −6e-11, net force
    ~2e-16 of the summed force magnitudes.
    """
    lat = make_lattice(units=3, side_m=12.0)
    k, _ = strut_stiffness(lat, EI_Nm2=1e3)
    m = node_masses(lat, total_kg=8.0)
    gamma = strut_damping(lat, k, zeta=0.1, particle_mass_kg=m[0])
    model = build_truss_spec(
        lat, masses=m, stiffness=k, damping=gamma, options=TrussModelOptions(timestep_s=0.02, integrator="RK4")
    ).compile()
    T = 0.01
    load = StrutTorqueLoad(lat, lat.struts_of_kind("y_edge", layer=1), command=lambda s: np.array([T, 0, 0]))
    probes = {
        "qpos": lambda s, d: d.qpos,
        "qvel": lambda s, d: d.qvel,
        "net_force": lambda s, d: d.xfrc_applied[:, :3].sum(axis=0),
        "abs_force": lambda s, d: np.abs(d.xfrc_applied[:, :3]).sum(),
    }
    res = Simulation(model=model, duration_s=40.0, loads=[load], probes=probes, record_every=25).run()
    assert res.status == "completed"
    t = res.records["t"]
    x = node_positions_from_qpos(model, res.records["qpos"], n_nodes=lat.n_nodes)
    v = res.records["qvel"].reshape(t.size, -1, 3)
    I1 = particle_inertia(lat.nodes, m).moments[0]
    R, _ = best_fit_rotation(lat.nodes, x)
    phi = np.arctan2(R[:, 2, 1], R[:, 1, 1])  # rotation about x1
    alpha = np.sum(phi * 0.5 * t**2) / np.sum((0.5 * t**2) ** 2)  # least squares φ = ½ α t²
    assert abs(alpha / (T / I1) - 1) < 0.02
    Lx = np.sum(m[None, :] * np.cross(x, v)[..., 0], axis=1)
    np.testing.assert_allclose(Lx[-1], T * t[-1], rtol=0.02)
    np.testing.assert_allclose(res.records["net_force"][1:], 0.0, atol=1e-14 * res.records["abs_force"][1:].max())
    P = np.sum(m[None, :, None] * v, axis=1)
    assert np.abs(P).max() < 1e-12 * T * t[-1] / lat.cube_edge_m
    assert np.abs(rotation_angle(R[-1]) - abs(phi[-1])) < 1e-3 * abs(phi[-1])  # no cross-axis motion


# ------------------------------------------------------------------------------ cantilever


CASES = [("A", 100.0, 1e3, 100.0), ("B", 100.0, 1e2, 100.0), ("C", 100.0, 1e1, 100.0), ("orbital", 75.0, 1e3, 200.0)]


@pytest.mark.parametrize("case,d,EI,M", CASES)
def test_cantilever_linear_matches_beam_formula(case, d, EI, M):
    """Cantilever linear solve, calibrated stiffness: δ = PL³/(3EI) within 10 % and
    EI_eff/EI = 1 ± 0.02 (our calibration tolerance). P gives δ = 0.3 % of d. Measured: 1 ± 1e-9 (calibration is one
    exact linear scaling; this checks that the cached factor carries over to every d and EI)."""
    lat = make_lattice(units=19, side_m=d)
    k, _ = strut_stiffness(lat, EI_Nm2=EI, calibration="cantilever")
    P = 0.003 * d * 3 * EI / d**3
    res = cantilever_linear(lat, k, load_N=P)
    beam = P * d**3 / (3 * EI)
    assert abs(res.tip_deflection_m / beam - 1) < 0.10
    assert abs(res.EI_eff_Nm2 / EI - 1) < 0.02


def _cantilever_cfg(path, *overrides):
    return load_config(path, list(overrides))


def test_cantilever_mujoco_settle_small_lattice():
    """The cantilever scenario (clamp, tip load, settle damping) on a 4 × 4-cube lattice: the
    MuJoCo settle matches the linear solve within 1 % and the tip speed criterion
    is met. ω₁ ≈ 0.2 rad/s, so 150 s (≈ 30/ω₁) of Euler at 0.05 s settle it."""
    cfg = _cantilever_cfg(
        MODELS / "cantilever.toml",
        "lattice.units=4",
        "lattice.side_m=20.0",
        "mass.total_kg=4.0",
        "stiffness.EI_Nm2=100.0",
        "cantilever.load_N=0.003",
        "sim.timestep_s=0.05",
        "sim.duration_s=150.0",
        "sim.progress=false",
    )
    sc = build_truss_scenario(cfg)
    summary, _ = sc.postprocess(sc.simulation().run())
    assert summary["status"] == "completed"
    assert summary["settled"]
    assert summary["linear_vs_mujoco_rel_diff"] < 0.01
    assert abs(summary["EI_ratio_calibrated"] - 1) < 0.02
    assert summary["tip_deflection_over_side"] < 0.005


@pytest.mark.slow
@pytest.mark.parametrize("case,EI", [("A", 1e3), ("B", 1e2), ("C", 1e1)])
def test_cantilever_mujoco_settle_cases(case, EI):
    """Cantilever MuJoCo settle of the full 800-node lattice for Cases A–C (calibrated): δ within
    10 % of PL³/(3EI), within 1 % of the linear solve, settled. The shipped config is Case A;
    for B and C the load (δ = 0.33 % of d), the step (ω_max ∝ √EI) and the duration (∝ 1/ω₁ ∝
    1/√EI) are scaled so every case takes the same 18 000 Euler steps."""
    s = np.sqrt(1e3 / EI)
    cfg = _cantilever_cfg(
        MODELS / "cantilever.toml",
        f"stiffness.EI_Nm2={EI}",
        f"cantilever.load_N={1e-3 * EI / 1e3}",
        f"sim.timestep_s={0.1 * s}",
        f"sim.duration_s={1800.0 * s}",
        "sim.progress=false",
    )
    sc = build_truss_scenario(cfg)
    summary, _ = sc.postprocess(sc.simulation().run())
    assert summary["status"] == "completed" and summary["settled"]
    assert abs(summary["tip_deflection_mujoco_m"] / summary["beam_deflection_m"] - 1) < 0.10
    assert summary["linear_vs_mujoco_rel_diff"] < 0.01
    assert abs(summary["EI_ratio_calibrated"] - 1) < 0.02


@pytest.mark.slow
def test_cantilever_mujoco_settle_orbital_truss():
    """The shipped 75 m config: settled, within 1 % of the linear solve and 10 % of the beam."""
    sc = build_truss_scenario(_cantilever_cfg(MODELS / "cantilever_75m.toml", "sim.progress=false"))
    summary, _ = sc.postprocess(sc.simulation().run())
    assert summary["status"] == "completed" and summary["settled"]
    assert abs(summary["tip_deflection_mujoco_m"] / summary["beam_deflection_m"] - 1) < 0.10
    assert summary["linear_vs_mujoco_rel_diff"] < 0.01


# ------------------------------------------------------------------------------ NumPy reference


CASE_A_DISTRIBUTED = MODELS / "dist_vs_central/case_a_distributed_bangbang.toml"


def test_numpy_rk4_reference_agrees_with_mujoco_rk4():
    """RK4 against the NumPy reference: Case A (800 nodes, distributed bang-bang, calibrated, ζ_s = 0.1), 60 s:
    MuJoCo RK4 at 0.1 s with the load held over each step vs the NumPy RK4 with the load at
    every stage. Attitude within 1e-3 rad and surface SD within 2 % of its peak, at every
    3-s sample (measured: 3e-14 rad and 3e-11, the held load costs nothing here)."""
    cfg = load_config(
        CASE_A_DISTRIBUTED,
        [
            "sim.duration_s=60",
            "sim.timestep_s=0.1",
            "sim.integrator='RK4'",
            "sim.load_timing='start'",
            "sim.record_every=30",
            "sim.progress=false",
        ],
    )
    sc = build_truss_scenario(cfg)
    res = sc.simulation().run()
    assert res.status == "completed"
    x_mj = sc.node_positions(res.records["qpos"])
    system, external, x0, v0 = from_truss_scenario(sc)
    _, _, rec = rk4_run(system, x0, v0, dt=0.1, duration=60.0, external=external, record_every=30)
    np.testing.assert_allclose(rec["t"], res.records["t"], atol=1e-9)
    lat = sc.tm.lattice
    Ra, _ = best_fit_rotation(lat.nodes, rec["x"])
    Rb, _ = best_fit_rotation(lat.nodes, x_mj)
    assert np.max(rotation_angle(Rb, relative_to=Ra)) < 1e-3
    assert rotation_angle(Ra[-1]) > 1e-3  # it did rotate: the check is not vacuous
    sda, sdb = surface_sd(rec["x"][:, lat.top_nodes]), surface_sd(x_mj[:, lat.top_nodes])
    assert np.max(np.abs(sdb - sda)) < 0.02 * np.max(sda)


def test_reference_conserves_momentum_and_matches_mujoco_free_vibration():
    """The NumPy RK4 on its own: γ = 0, no load, 10 s at 0.005 s on a 2 × 2-cube lattice — linear
    momentum to 1e-12 relative, and the same trajectory as MuJoCo RK4 to 1e-9 a (both are the
    same RK4 of the same equations; only rounding differs)."""
    lat, m, k, model = small_model(integrator="RK4", dt=0.005)
    data = mujoco.MjData(model)
    randomise(model, data, lat, np.random.default_rng(5))
    x0 = node_positions_from_qpos(model, data.qpos, n_nodes=lat.n_nodes)
    v0 = data.qvel.reshape(-1, 3).copy()
    system = SpringMassLattice(masses=m, struts=lat.struts, k=k, l0=lat.rest_length, gamma=0.0)
    x, v, _ = rk4_run(system, x0, v0, dt=0.005, duration=10.0)
    for _ in range(2000):
        mujoco.mj_step(model, data)
    x_mj = node_positions_from_qpos(model, data.qpos, n_nodes=lat.n_nodes)
    np.testing.assert_allclose(x, x_mj, rtol=0, atol=1e-9 * lat.cube_edge_m)
    P0, _ = momentum(m, x0, v0)
    P, _ = momentum(m, x, v)
    np.testing.assert_allclose(P, P0, rtol=0, atol=1e-12 * np.sum(m * np.linalg.norm(v0, axis=1)))


@pytest.mark.parametrize("tau_max,tol", [(0.0, 1e-12), (0.01, 1e-4)])
def test_reference_from_scenario_with_initial_attitude_and_rate(small_truss_tree, tau_max, tol):
    """``from_truss_scenario`` starts from the scenario's initial state (rotated attitude q0 and
    rigid rate ω₀) and applies its torque load: 10 s of the small truss at RK4 0.1 s agree with
    the MuJoCo runner. Without load both are the same RK4 (measured 1e-15 a; asserted 1e-12 a).
    With the distributed torque the only difference is the load held over each MuJoCo step vs
    evaluated per RK stage, an O(δt) effect while the lattice spins (measured 7e-6 a at 0.1 s
    and 7e-7 a at 0.01 s; asserted 1e-4 a)."""
    tree = apply_overrides(
        small_truss_tree,
        [
            "sim.duration_s=10.0",
            "sim.record_every=100",
            f"profile.tau_max_Nm={tau_max}",
            "initial.q0_wxyz=[0.9238795325112867, 0.0, 0.3826834323650898, 0.0]",
            "initial.omega0_rad_s=[0.01, -0.02, 0.005]",
        ],
    )
    sc = build_truss_scenario(parse_config(tree))
    res = sc.simulation().run()
    assert res.status == "completed"
    x_mj = sc.node_positions(res.records["qpos"])
    system, external, x0, v0 = from_truss_scenario(sc)
    a = sc.tm.lattice.cube_edge_m
    np.testing.assert_allclose(x0, x_mj[0], rtol=0, atol=1e-12 * a)
    assert np.abs(x0 - sc.tm.lattice.nodes).max() > 0.1 * a  # really rotated
    x, _, _ = rk4_run(system, x0, v0, dt=0.1, duration=10.0, external=external)
    np.testing.assert_allclose(x, x_mj[-1], rtol=0, atol=tol * a)


@pytest.mark.parametrize("fixed", [(), (0, 5)])
def test_body_kinematics_equals_mujoco_kinematics(fixed):
    """BodyKinematics (plain views for a free lattice, index arrays when nodes are clamped) reads
    the same node positions and velocities as MuJoCo's own kinematics."""
    from magsail_mj.sim import BodyKinematics

    lat, m, k, model = small_model(units=2, fixed=fixed)
    d = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    d.qpos[:] = rng.normal(scale=0.1, size=model.nq)
    d.qvel[:] = rng.normal(scale=0.1, size=model.nv)
    kin = BodyKinematics(model)
    assert (kin._part_block is not None) == (not fixed)
    kin.update(d)
    mujoco.mj_forward(model, d)
    np.testing.assert_array_equal(kin.pos[1:], d.xpos[1:])
    vel = np.zeros((model.nbody, 6))
    for b in range(1, model.nbody):
        mujoco.mj_objectVelocity(model, d, mujoco.mjtObj.mjOBJ_BODY, b, vel[b], 0)
    np.testing.assert_allclose(kin.vel[1:], vel[1:, 3:], rtol=0, atol=1e-15)
