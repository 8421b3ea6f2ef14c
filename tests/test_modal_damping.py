"""Modes, Caughey damping and the co-rotated damping load (Robb et al. 2022b, Eqs. 13–15; Caughey & O'Kelly 1965).

Small lattices (3–5 units) only. Tolerances are relative to the natural scale of each quantity
(``|γ| |v|`` for forces, the largest entry for matrices) and stated at each assertion.
"""

from __future__ import annotations

import magsail_mj  # noqa: F401  (picks the GL backend before mujoco is imported)
import mujoco
import numpy as np
import pytest

from magsail_mj.lattice.modes import (
    SCHEDULES,
    caughey_low_rank,
    caughey_matrix,
    damping_ratios,
    lattice_modes,
    modes_cache_dir,
    schedule_record,
    stability_products,
)
from magsail_mj.estimation.attitude import so3_exp
from magsail_mj.lattice.geometry import make_lattice, stiffness_matrix
from magsail_mj.lattice.properties import strut_stiffness
from magsail_mj.loads.base import StepState
from magsail_mj.lattice.modal_damping import ModalDampingLoad, passive_damping
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec

SIDE = 60.0
SIGMA = 0.1
EI = 1e4


def _setup(units: int, EI_Nm2: float = EI):
    lat = make_lattice(units=units, side_m=SIDE)
    k, _ = strut_stiffness(lat, EI_Nm2=EI_Nm2, calibration="formula")
    m = np.full(lat.n_nodes, SIGMA * SIDE**2 / lat.n_nodes)
    return lat, k, m


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("modes")


@pytest.fixture(scope="module")
def small(cache):
    """N = 4 lattice (50 nodes, 150 DOF) with its modes and the paper_max γ (n_low = 30)."""
    lat, k, m = _setup(4)
    modes = lattice_modes(lat.nodes, lat.struts, k, m, cache_dir=cache)
    xi = damping_ratios(modes.omega, schedule="paper_max", n_low=30)
    gamma = caughey_matrix(modes, xi)
    return lat, k, m, modes, xi, gamma


def _rand_rotation(rng) -> np.ndarray:
    return so3_exp(rng.normal(size=3) * 1.2)


# ----------------------------------------------------------------------------- stiffness, modes
def test_stiffness_symmetric_six_zero_modes_annihilates_rigid(small):
    lat, k, m, *_ = small
    K = stiffness_matrix(lat.nodes, lat.struts, k).toarray()
    scale = np.abs(K).max()
    assert np.abs(K - K.T).max() <= 1e-14 * scale
    lam = np.linalg.eigvalsh(K)
    assert np.all(np.abs(lam[:6]) < 1e-12 * lam[-1])  # six zero eigenvalues
    assert lam[6] > 1e-6 * lam[-1]  # and only six
    c = lat.nodes.mean(axis=0)
    for e in np.eye(3):
        t = np.tile(e, lat.n_nodes)  # rigid translation
        w = np.cross(e, lat.nodes - c).ravel()  # infinitesimal rotation
        assert np.abs(K @ t).max() <= 1e-12 * scale
        assert np.abs(K @ w).max() <= 1e-12 * scale * SIDE


def test_modes_mass_orthonormal_sorted_rigid_clamped(small):
    lat, k, m, modes, *_ = small
    M = modes.mass_diag
    PtMP = modes.phi.T @ (M[:, None] * modes.phi)
    assert np.abs(PtMP - np.eye(modes.n_dof)).max() < 1e-10
    assert np.all(np.diff(modes.omega) >= 0)
    assert np.all(modes.omega[:6] == 0) and modes.omega[6] > 0
    # Phi^T K Phi = diag(omega^2) for the elastic modes
    K = stiffness_matrix(lat.nodes, lat.struts, k).toarray()
    PtKP = modes.phi.T @ K @ modes.phi
    assert np.allclose(np.diag(PtKP)[6:], modes.omega[6:] ** 2, rtol=1e-9)
    assert np.abs(PtKP - np.diag(np.diag(PtKP))).max() < 1e-9 * modes.omega[-1] ** 2


def test_modes_cache_shared_across_EI_and_env_var(cache, monkeypatch, tmp_path):
    lat, k, m = _setup(3)
    a = lattice_modes(lat.nodes, lat.struts, k, m, cache_dir=tmp_path)
    files = list(tmp_path.glob("modes_*.npz"))
    assert len(files) == 1
    b = lattice_modes(lat.nodes, lat.struts, 10.0 * k, 2.0 * m, cache_dir=tmp_path)  # cache hit
    assert len(list(tmp_path.glob("modes_*.npz"))) == 1 and b.key == a.key
    assert np.allclose(b.omega, a.omega * np.sqrt(5.0), rtol=1e-12)
    c = lattice_modes(lat.nodes, lat.struts, 10.0 * k, 2.0 * m, use_cache=False)
    assert np.allclose(c.omega, b.omega, rtol=1e-9, atol=1e-12 * b.omega[-1])
    PtMP = b.phi.T @ (b.mass_diag[:, None] * b.phi)
    assert np.abs(PtMP - np.eye(b.n_dof)).max() < 1e-10
    monkeypatch.setenv("MAGSAIL_CACHE_DIR", str(tmp_path / "env"))
    assert modes_cache_dir() == tmp_path / "env"
    assert modes_cache_dir(tmp_path) == tmp_path


def test_modes_errors_name_the_argument():
    lat, k, m = _setup(3)
    with pytest.raises(ValueError, match="masses"):
        lattice_modes(lat.nodes, lat.struts, k, m[:-1], use_cache=False)
    with pytest.raises(ValueError, match="k:"):
        lattice_modes(lat.nodes, lat.struts, -k, m, use_cache=False)
    with pytest.raises(ValueError, match="n_rigid"):
        lattice_modes(lat.nodes, lat.struts, k, m, n_rigid=5, use_cache=False)
    with pytest.raises(ValueError, match="schedule"):
        damping_ratios(np.arange(10.0), schedule="rayleigh")


# ----------------------------------------------------------------------------- schedules
def test_schedules(cache):
    lat, k, m = _setup(5)  # 216 DOF: 210 elastic modes
    modes = lattice_modes(lat.nodes, lat.struts, k, m, cache_dir=cache)
    assert set(SCHEDULES) == {"paper_max", "capped_rayleigh"}
    pm = damping_ratios(modes.omega, schedule="paper_max")
    cr = damping_ratios(modes.omega, schedule="capped_rayleigh")
    for xi in (pm, cr):
        assert np.all(xi[:6] == 0)  # rigid modes: no damping
        assert np.all(xi[6:106] == 0.01)  # first 100 elastic modes (counted from 1)
    assert np.all(pm[106:] == 10.0)
    assert np.all((cr[106:] >= 0.02 - 1e-12) & (cr[106:] <= 0.2))
    assert cr[106] == pytest.approx(0.02 * modes.omega[106] / modes.omega[105])
    rec = schedule_record(schedule="paper_max")
    assert rec["damping_mode_counting"] == "first_elastic"


def test_stability_products(small):
    *_, modes, xi, _ = small
    sp = stability_products(modes.omega, xi, dt=0.05)
    assert sp.damping_product == pytest.approx(2 * 10.0 * modes.omega[-1] * 0.05)
    xi_max = 10.0
    assert sp.fastest_root_product == pytest.approx(modes.omega[-1] * (xi_max + np.sqrt(xi_max**2 - 1)) * 0.05)
    assert sp.omega_max_dt == pytest.approx(modes.omega[-1] * 0.05)


# ----------------------------------------------------------------------------- Caughey matrix
def test_gamma_is_modal_diagonal(small):
    *_, modes, xi, gamma = small
    D = modes.phi.T @ gamma @ modes.phi
    target = 2.0 * xi * modes.omega
    assert np.abs(D - np.diag(target)).max() < 1e-10 * target.max()
    assert np.abs(gamma - gamma.T).max() == 0.0


def test_low_rank_equals_dense(cache):
    lat, k, m = _setup(5)
    modes = lattice_modes(lat.nodes, lat.struts, k, m, cache_dir=cache)
    for n_low in (100, 20):
        xi = damping_ratios(modes.omega, schedule="capped_rayleigh", n_low=n_low)
        dense = caughey_matrix(modes, xi)
        lr = caughey_low_rank(modes, xi, n_low=n_low)
        assert lr.U.shape[1] == n_low  # rank n_low correction
        assert lr.c == pytest.approx(4 * 0.01 / modes.omega[6 + n_low - 1])
        K = stiffness_matrix(lat.nodes, lat.struts, k).toarray()
        assert np.abs(lr.c * K + lr.correction_matrix() - dense).max() < 1e-10 * np.abs(dense).max()
        v = np.random.default_rng(1).normal(size=modes.n_dof)
        assert np.allclose(lr.apply(v), lr.correction_matrix() @ v, rtol=1e-12, atol=1e-14)


def test_low_rank_load_plus_tendon_damping_equals_dense_in_mujoco(cache):
    """Tendon dashpots b = c k (MuJoCo passive) + low-rank load = dense load (undeformed state)."""
    lat, k, m = _setup(4)
    common = dict(
        nodes=lat.nodes,
        struts=lat.struts,
        k=k,
        masses=m,
        schedule="capped_rayleigh",
        n_low=30,
        cache_dir=cache,
        dtype=np.float64,
    )
    dense = ModalDampingLoad.for_lattice(**common)
    low = ModalDampingLoad.for_lattice(**common, form="low_rank")
    b = low.tendon_damping(k)
    model = build_truss_spec(lat, masses=m, stiffness=k, damping=b).compile()
    data = mujoco.MjData(model)
    v = np.random.default_rng(2).normal(size=(lat.n_nodes, 3)) * 0.1
    data.qvel[:] = v.ravel()
    mujoco.mj_forward(model, data)
    F_mj = data.qfrc_passive.reshape(-1, 3) + low.forces(lat.nodes, v)
    F_dense = dense.forces(lat.nodes, v)
    assert np.abs(F_mj - F_dense).max() < 1e-9 * np.abs(F_dense).max()
    again = ModalDampingLoad.for_lattice(**common, modes=dense.modes)  # precomputed modes
    assert np.array_equal(again.forces(lat.nodes, v), F_dense)
    assert np.array_equal(again.last_forces, F_dense)


# ----------------------------------------------------------------------------- co-rotation
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_corotated_gamma_annihilates_rigid_velocity_of_rotated_lattice(small, dtype):
    lat, k, m, modes, xi, gamma = small
    load = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma, dtype=dtype)
    rng = np.random.default_rng(3)
    scale = np.abs(gamma).max()
    for _ in range(5):
        R = _rand_rotation(rng)
        d = rng.normal(size=3) * 50
        pos = lat.nodes @ R.T + d
        c = m @ pos / m.sum()
        w = rng.normal(size=3) * 0.05
        vel = rng.normal(size=3) + np.cross(w, pos - c)  # rigid velocity field
        F = load.forces(pos, vel)
        vmag = np.abs(vel).max()
        assert np.abs(F).max() < 1e-10 * scale * vmag  # both dtypes (rigid part removed first)
        assert abs(load.last_power_W) < 1e-10 * scale * vmag**2 * lat.n_nodes
        assert np.allclose(load.last_R, R, atol=1e-12)
    # the paper's literal inertial form does damp the rotated rigid field
    lit = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma, frame="inertial", dtype=dtype)
    assert np.abs(lit.forces(pos, vel)).max() > 1e-3 * scale * vmag


def test_rigid_90deg_rotation_at_constant_rate_feels_no_damping(small):
    lat, k, m, modes, xi, gamma = small
    load = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma)  # float32 default
    lit = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma, frame="inertial")
    axis = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
    rate = 0.01  # rad/s, 90 deg in 157 s
    xfrc = np.zeros((lat.n_nodes + 1, 6))
    worst, worst_lit = 0.0, 0.0
    ref = np.abs(gamma).max() * rate * SIDE
    for t in np.linspace(0.0, 0.5 * np.pi / rate, 19):
        R = so3_exp(axis * rate * t)
        pos = lat.nodes @ R.T
        vel = np.cross(rate * axis, pos)
        state = StepState(
            t=t,
            pos=np.vstack([np.zeros(3), pos]),
            vel=np.vstack([np.zeros(3), vel]),
            xquat=np.tile([1.0, 0, 0, 0], (lat.n_nodes + 1, 1)),
            omega=np.zeros((lat.n_nodes + 1, 3)),
        )
        xfrc[:] = 0.0
        load.add(state, xfrc)
        assert np.all(xfrc[0] == 0) and np.all(xfrc[:, 3:] == 0)
        worst = max(worst, np.abs(xfrc).max())
        worst_lit = max(worst_lit, np.abs(lit.forces(pos, vel)).max())
    assert worst < 1e-10 * ref
    assert worst_lit > 1e-2 * ref  # the literal form would damp it


def test_force_has_no_net_force_and_power_matches(small):
    lat, k, m, modes, xi, gamma = small
    load = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma, dtype=np.float64)
    rng = np.random.default_rng(4)
    R = _rand_rotation(rng)
    pos = (lat.nodes + rng.normal(size=lat.nodes.shape) * 0.05) @ R.T
    vel = rng.normal(size=pos.shape) * 0.01
    F = load.forces(pos, vel)
    assert np.abs(F.sum(axis=0)).max() < 1e-12 * np.abs(F).max() * lat.n_nodes
    Rb = load.last_R
    vb = (vel @ Rb).ravel()
    assert load.last_power_W == pytest.approx(vb @ gamma @ vb, rel=1e-12)
    assert load.last_power_W > 0
    f32 = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma, dtype=np.float32)
    assert np.abs(f32.forces(pos, vel) - F).max() < 1e-5 * np.abs(F).max()


# ----------------------------------------------------------------------------- dynamics
def _perturbed_model(lat, k, m, dt, modes=None, spin=0.002):
    """RK4 truss model with random elastic velocities (rigid part removed) plus a rigid spin."""
    model = build_truss_spec(
        lat, masses=m, stiffness=k, damping=0.0, options=TrussModelOptions(timestep_s=dt, integrator="RK4")
    ).compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(5)
    v = rng.normal(size=model.nv) * 0.05
    if modes is not None:
        v -= modes.rigid_phi @ (modes.rigid_phi.T @ (modes.mass_diag * v))
    data.qvel[:] = v
    data.qvel.reshape(-1, 3)[:] += np.cross([0.0, 0.0, spin], lat.nodes)
    return model, data


def _energy(lat, k, m, data):
    x = lat.nodes + data.qpos.reshape(-1, 3)
    r = x[lat.struts[:, 1]] - x[lat.struts[:, 0]]
    U = 0.5 * np.sum(k * (np.linalg.norm(r, axis=1) - lat.rest_length) ** 2)
    v = data.qvel.reshape(-1, 3)
    return U + 0.5 * np.sum(m[:, None] * v * v)


@pytest.mark.parametrize("inject", ["xfrc", "passive"])
def test_energy_decreases_monotonically_with_damping(small, inject):
    lat, k, m, modes, xi, gamma = small
    dt = 0.05
    assert stability_products(modes.omega, xi, dt=dt).damping_product < 1.5
    load = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma)
    model, data = _perturbed_model(lat, k, m, dt, modes)
    E = [_energy(lat, k, m, data)]
    L0 = np.sum(m[:, None] * np.cross(lat.nodes + data.qpos.reshape(-1, 3), data.qvel.reshape(-1, 3)), axis=0)
    spin_E = 0.5 * np.sum(m[:, None] * np.cross([0.0, 0.0, 0.002], lat.nodes) ** 2)

    def step():
        if inject == "xfrc":
            data.xfrc_applied[1:, :3] = load.forces(lat.nodes + data.qpos.reshape(-1, 3), data.qvel.reshape(-1, 3))
        mujoco.mj_step(model, data)
        E.append(_energy(lat, k, m, data))

    if inject == "passive":
        with passive_damping(model, load) as cb:
            for _ in range(2000):
                step()
        assert cb.calls == 4 * 2000  # once per RK4 stage
    else:
        for _ in range(2000):
            step()
    E = np.asarray(E)
    assert np.all(np.diff(E) <= 1e-12 * E[0])  # monotone
    assert E[-1] - spin_E < 0.3 * (E[0] - spin_E)  # elastic energy (0.16 measured)
    assert E[-1] > 0.999 * spin_E  # the rigid spin is not damped
    L1 = np.sum(m[:, None] * np.cross(lat.nodes + data.qpos.reshape(-1, 3), data.qvel.reshape(-1, 3)), axis=0)
    assert np.abs(L1 - L0).max() < 1e-2 * np.abs(L0).max()


# ----------------------------------------------------------------------------- passive hook
def test_passive_context_manager_installs_restores_and_ignores_other_models(small):
    lat, k, m, modes, xi, gamma = small
    load = ModalDampingLoad(modes=modes, nodes=lat.nodes, gamma=gamma)
    model, data = _perturbed_model(lat, k, m, 0.1)
    other, other_data = _perturbed_model(lat, k, m, 0.1)
    assert mujoco.get_mjcb_passive() is None
    with pytest.raises(ZeroDivisionError):
        with passive_damping(model, load) as cb:
            assert mujoco.get_mjcb_passive() is cb
            with pytest.raises(RuntimeError, match="already installed"):
                with passive_damping(model, load):
                    pass
            mujoco.mj_step(other, other_data)
            assert cb.calls == 0  # not this callback's model
            mujoco.mj_forward(model, data)
            assert cb.calls == 1
            assert np.abs(data.qfrc_passive).max() > 0
            1 / 0
    assert mujoco.get_mjcb_passive() is None  # removed, also on error
