"""Strut stiffness, stiffness calibration, particle masses and strut damping of a lattice.

Robb et al. 2022a: masses, strut stiffness from EI, strut damping (ours: the paper gives none),
cantilever check and calibration. All pure NumPy/SciPy.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.sparse.linalg import spsolve

from magsail_mj.lattice.geometry import (
    Lattice,
    axial_rigidity_from_EI,
    make_lattice,
    node_index,
    stiffness_matrix,
)

__all__ = [
    "CantileverResult",
    "cantilever_linear",
    "calibration_factor",
    "strut_stiffness",
    "node_masses",
    "strut_damping",
    "clamped_nodes",
    "central_cube_nodes",
    "loaded_nodes",
]


@dataclass(frozen=True)
class CantileverResult:
    """Linear cantilever of the lattice.

    ``tip_deflection_m`` is the mean deflection δ of the loaded (i = N−1) nodes along −z1;
    ``EI_eff_Nm2 = P L³ / (3 δ)`` with ``L = d``.
    """

    load_N: float
    length_m: float
    tip_deflection_m: float
    EI_eff_Nm2: float


def clamped_nodes(lattice: Lattice) -> np.ndarray:
    """Nodes with i = 0 (both layers): the clamped edge of the cantilever."""
    return np.flatnonzero(lattice.ijk[:, 0] == 0)


def loaded_nodes(lattice: Lattice) -> np.ndarray:
    """Nodes with i = N−1 (both layers): the loaded free edge of the cantilever."""
    return np.flatnonzero(lattice.ijk[:, 0] == lattice.units)


def cantilever_linear(lattice: Lattice, k: np.ndarray, *, load_N: float) -> CantileverResult:
    """Static tip deflection of the clamped lattice under a total transverse load ``load_N``.

    Solves ``K_ff u_f = f_f`` (free dofs, sparse LU) with the load split equally over the 2N
    nodes at i = N−1, along −z1.
    """
    K = stiffness_matrix(lattice.nodes, lattice.struts, k).tocsc()
    clamp = clamped_nodes(lattice)
    tip = loaded_nodes(lattice)
    fixed = np.zeros(3 * lattice.n_nodes, dtype=bool)
    fixed[(3 * clamp[:, None] + np.arange(3)).ravel()] = True
    free = np.flatnonzero(~fixed)
    f = np.zeros(3 * lattice.n_nodes)
    f[3 * tip + 2] = -load_N / tip.size
    u = np.zeros_like(f)
    u[free] = spsolve(K[free][:, free], f[free])
    delta = -float(np.mean(u[3 * tip + 2]))
    L = lattice.side_m
    return CantileverResult(load_N=load_N, length_m=L, tip_deflection_m=delta, EI_eff_Nm2=load_N * L**3 / (3.0 * delta))


@lru_cache(maxsize=32)
def _ratio_formula(units: int, diagonals: str) -> float:
    """EI_eff / EI of the formula stiffness (independent of d and EI)."""
    lat = make_lattice(units=units, side_m=float(units), diagonals=diagonals)
    EI = 1.0
    EA = axial_rigidity_from_EI(EI, nodes_per_side=lat.nodes_per_side, cube_edge_m=lat.cube_edge_m)
    res = cantilever_linear(lat, EA / lat.rest_length, load_N=1e-6)
    return res.EI_eff_Nm2 / EI


def calibration_factor(lattice: Lattice, calibration: str) -> float:
    """Factor applied to the formula EA: ``EI / EI_eff`` for ``"cantilever"``, 1 for ``"formula"``.

    The in-plane diagonals stiffen the plate beyond Eq. 8, so the
    reproduction runs scale every strut's EA by one factor found from a linear cantilever solve.
    """
    if calibration == "formula":
        return 1.0
    if calibration == "cantilever":
        return 1.0 / _ratio_formula(lattice.units, lattice.diagonals)
    raise ValueError(f"calibration: must be 'cantilever' or 'formula', got {calibration!r}")


def strut_stiffness(lattice: Lattice, *, EI_Nm2: float, calibration: str = "cantilever") -> tuple[np.ndarray, float]:
    """Per-strut spring constants ``k_s = c · EA / l0_s`` and the calibration factor ``c``.

    ``EA = 2 EI / (N a²)``; every strut has the same EA.
    """
    if not EI_Nm2 > 0:
        raise ValueError(f"EI_Nm2: must be > 0, got {EI_Nm2!r}")
    c = calibration_factor(lattice, calibration)
    EA = c * axial_rigidity_from_EI(EI_Nm2, nodes_per_side=lattice.nodes_per_side, cube_edge_m=lattice.cube_edge_m)
    return EA / lattice.rest_length, c


def central_cube_nodes(lattice: Lattice) -> np.ndarray:
    """The 8 nodes of the central cube (for odd ``units`` it is unique)."""
    n = lattice.units
    i0 = (n - 1) // 2
    N = lattice.nodes_per_side
    ii, jj, kk = np.meshgrid([i0, i0 + 1], [i0, i0 + 1], [0, 1], indexing="ij")
    return np.sort(node_index(ii.ravel(), jj.ravel(), kk.ravel(), N))


def node_masses(
    lattice: Lattice,
    *,
    total_kg: float,
    central_fraction: float = 0.0,
    point_masses: list[tuple[int, float]] | tuple = (),
) -> np.ndarray:
    """Particle masses.

    ``(1 − central_fraction) · total_kg`` is spread uniformly over all nodes; the
    ``central_fraction`` part (the centralised actuator mass) is split equally over the 8 nodes of
    the central cube, keeping the centre of mass at the geometric centre. Extra
    ``point_masses`` ``(node, kg)`` are added on top.
    """
    if not total_kg > 0:
        raise ValueError(f"total_kg: must be > 0, got {total_kg!r}")
    if not 0.0 <= central_fraction < 1.0:
        raise ValueError(f"central_fraction: must be in [0, 1), got {central_fraction!r}")
    m = np.full(lattice.n_nodes, (1.0 - central_fraction) * total_kg / lattice.n_nodes)
    if central_fraction > 0:
        m[central_cube_nodes(lattice)] += central_fraction * total_kg / 8.0
    for node, kg in point_masses:
        if not 0 <= int(node) < lattice.n_nodes:
            raise ValueError(f"point_masses: node {node} is outside 0..{lattice.n_nodes - 1}")
        m[int(node)] += float(kg)
    return m


def strut_damping(lattice: Lattice, k: np.ndarray, *, zeta: float, particle_mass_kg: float) -> float:
    """Strut dashpot ``γ = 2 ζ √(k_edge m_p / 2)``.

    ``k_edge`` is the (calibrated) spring constant of a cube-edge strut and ``m_p`` the
    distributed-case particle mass; the same γ is used for every strut.
    """
    if zeta < 0:
        raise ValueError(f"zeta: must be >= 0, got {zeta!r}")
    k_edge = float(k[np.argmin(lattice.rest_length)])
    return 2.0 * zeta * np.sqrt(k_edge * particle_mass_kg / 2.0)
