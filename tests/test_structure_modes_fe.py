"""The structure modes against independent tools: scikit-fem's finite elements of the same beam,
and a MuJoCo simulation of a strut lattice ringing at the computed frequency."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy import linalg
from skfem import Basis, BilinearForm, ElementLineHermite, ElementLineP1, MeshLine, asm, condense
from skfem.helpers import dd, grad

from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec
from magsail_mj.structure.generators.plates import lattice_structure
from magsail_mj.structure.model import Members, Structure
from magsail_mj.structure.modes import structure_modes

L_M, RHO_A = 10.0, 0.5
EA_N, EI_NM2, GJ_NM2 = 1.0e6, (2.0e3, 3.0e3), 1.0e3
# a graded mesh (element lengths from 0.31 m to 0.66 m) so that no uniform-mesh symmetry hides an error
X_M = L_M * np.linspace(0.0, 1.0, 21) ** 1.3


def beam_structure(*, clamped: bool) -> Structure:
    p = np.column_stack([X_M, np.zeros_like(X_M), np.zeros_like(X_M)])
    n = X_M.size - 1
    members = Members.build(
        np.stack([np.arange(n), np.arange(1, n + 1)], axis=1),
        positions_m=p,
        kind="beam",
        EA_N=EA_N,
        EI_Nm2=np.tile(EI_NM2, (n, 1)),
        GJ_Nm2=GJ_NM2,
        linear_density_kg_m=RHO_A,
    )
    fixed = np.zeros((n + 1, 6), dtype=bool)
    fixed[0] = clamped
    return Structure(name="boom", positions_m=p, node_mass_kg=np.zeros(n + 1), members=members, fixed_dofs=fixed)


def skfem_frequencies_Hz(element, rigidity: float, inertia: float, *, order: int, clamped: bool) -> np.ndarray:
    """Frequencies of ``∫ rigidity (dᵒu)(dᵒv) = ω² ∫ inertia u v`` on the graded mesh: order 2 with
    Hermite cubics (bending), order 1 with linear elements (axial, torsion); root dofs removed
    when clamped."""
    basis = Basis(MeshLine(X_M), element)

    @BilinearForm
    def stiffness(u, v, w):
        if order == 2:
            return rigidity * dd(u)[0, 0] * dd(v)[0, 0]
        return rigidity * grad(u)[0] * grad(v)[0]

    @BilinearForm
    def mass(u, v, w):
        return inertia * u * v

    K, M = asm(stiffness, basis), asm(mass, basis)
    if clamped:
        K, M, _, _ = condense(K, M, D=basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all())
    lam = linalg.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    return np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)


@pytest.mark.parametrize(("solver", "rel"), [("dense", 1e-7), ("sparse", 1e-9)])
@pytest.mark.parametrize("clamped", [True, False])
def test_beam_frequencies_equal_scikit_fem(clamped, solver, rel):
    """Bending (both planes, Hermite cubics), axial and torsion (linear elements, ``ρI_p =
    ρA (EI1 + EI2)/EA``) frequencies of a clamped and a free beam on a graded mesh equal scikit-fem's
    assembly of the same element spaces with exact quadrature (consistent mass). Same
    discretisation, so only the solvers' round-off differs: a dense solve's ε λ_max is up to 1e-9
    of the lowest λ here (measured 9e-9 in frequency: tolerance 1e-7); shift-invert keeps the low
    modes' relative accuracy (measured 5e-11: tolerance 1e-9)."""
    r = structure_modes(beam_structure(clamped=clamped), k=40, mass="consistent", solver=solver)
    ours = r.frequencies_Hz[r.n_zero :]
    rho_Ip = RHO_A * sum(EI_NM2) / EA_N
    families = [
        skfem_frequencies_Hz(ElementLineHermite(), EI_NM2[0], RHO_A, order=2, clamped=clamped),
        skfem_frequencies_Hz(ElementLineHermite(), EI_NM2[1], RHO_A, order=2, clamped=clamped),
        skfem_frequencies_Hz(ElementLineP1(), EA_N, RHO_A, order=1, clamped=clamped),
        skfem_frequencies_Hz(ElementLineP1(), GJ_NM2, rho_Ip, order=1, clamped=clamped),
    ]
    expected = np.sort(np.concatenate(families))
    expected = expected[expected > 1e-6 * expected.max()]  # free: 2 + 2 + 1 + 1 rigid modes dropped
    assert r.n_zero == (0 if clamped else 6)
    np.testing.assert_allclose(ours, expected[: ours.size], rtol=rel)


def zero_crossing_frequency_Hz(t_s: np.ndarray, q: np.ndarray) -> float:
    """Frequency from the first and last of the linearly interpolated zero crossings of ``q(t)``."""
    sign_change = np.flatnonzero(np.sign(q[:-1]) * np.sign(q[1:]) < 0)
    crossings = t_s[sign_change] - q[sign_change] * (t_s[sign_change + 1] - t_s[sign_change]) / (
        q[sign_change + 1] - q[sign_change]
    )
    return (crossings.size - 1) / (2.0 * (crossings[-1] - crossings[0]))


@pytest.mark.parametrize("mode", [6, 9])
def test_mujoco_lattice_rings_at_the_computed_frequency(mode):
    """A free two-layer lattice (2 × 2 cubes, unequal strut stiffness and node masses) as a MuJoCo
    model (slide-jointed node bodies, spring tendons, :func:`build_truss_spec`), started from a
    small displacement along one mode shape (amplitude 10⁻⁶ of the cube edge: geometric
    nonlinearity ~10⁻¹² of the frequency) and simulated with RK4 at 200 steps per period for 30
    periods. The modal coordinate ``φᵀ M x`` rings at the computed frequency: RK4's frequency error
    is (ω h)⁴/120 ≈ 1.6·10⁻⁷, the interpolated zero crossings are exact to O((ω h)³) per crossing
    over a 30-period span (< 10⁻⁶); tolerance 10⁻⁵ (measured 8·10⁻⁹ and 3·10⁻⁹)."""
    lat = make_lattice(units=2, side_m=2.0)
    rng = np.random.default_rng(7)
    k = 2e3 / lat.rest_length * rng.uniform(0.7, 1.3, lat.n_struts)
    masses = rng.uniform(0.5, 1.5, lat.n_nodes)
    structure = lattice_structure(lat, masses_kg=masses, EA_N=k * lat.rest_length, damping_Ns_m=0.0, name="small")
    r = structure_modes(structure, k=mode + 1)
    assert r.n_zero == 6
    f_Hz = float(r.frequencies_Hz[mode])
    phi = r.dof_shapes()[:, mode]  # node-major x, y, z: the model's qpos order
    h_s = 1.0 / (200.0 * f_Hz)
    spec = build_truss_spec(
        lat, masses=masses, stiffness=k, damping=0.0, options=TrussModelOptions(timestep_s=h_s, integrator="RK4")
    )
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[:] = 1e-6 * lat.cube_edge_m * phi / np.abs(phi).max()
    weights = np.repeat(masses, 3) * phi
    steps = 30 * 200
    q = np.empty(steps + 1)
    q[0] = weights @ data.qpos
    for i in range(steps):
        mujoco.mj_step(model, data)
        q[i + 1] = weights @ data.qpos
    assert zero_crossing_frequency_Hz(h_s * np.arange(steps + 1), q) == pytest.approx(f_Hz, rel=1e-5)
