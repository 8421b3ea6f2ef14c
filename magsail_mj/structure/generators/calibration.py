"""Linear cantilever of a strut structure and the calibration of its axial rigidity ``EA`` to a
target plate bending stiffness ``EI`` (pure NumPy/SciPy).

The rule is the shipped lattice's (:mod:`magsail_mj.lattice.properties`): the nodes of the
``root`` node set are clamped (all three translations), a total load ``P`` along −z is split
equally over the nodes of the ``tip`` node set, the linear static problem ``K_ff u_f = f_f`` is
solved on the free degrees of freedom with a sparse LU (``scipy.sparse.linalg.spsolve``, ``K`` the
assembled axial stiffness of :func:`magsail_mj.lattice.geometry.stiffness_matrix`), and the mean
tip deflection ``δ`` along −z gives the effective Euler–Bernoulli bending stiffness

    EI_eff = P L³ / (3 δ),

``L`` the cantilever length: the distance along x from the mean position of the root nodes to
the mean position of the tip nodes (the plate side for a plate clamped along one edge and loaded
along the opposite one), unless given. Every spring constant ``EA / l0`` is linear in ``EA``, so
``EI_eff`` is too and one solve at a reference ``EA`` calibrates it:
``EA = EA_ref · EI / EI_eff(EA_ref)``.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
from scipy.sparse.linalg import MatrixRankWarning, spsolve

from magsail_mj.lattice.geometry import stiffness_matrix
from magsail_mj.lattice.properties import CantileverResult
from magsail_mj.structure.generators.common import check_positive
from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError

__all__ = ["CantileverResult", "cantilever", "calibrate_axial_rigidity"]

#: Relative tolerance of the check that a structure factory's member EA is proportional to its
#: ``EA_N`` argument (the calibration's one solve relies on it).
PROPORTIONAL_RTOL = 1e-12


def _node_set(structure: Structure, name: str, argument: str) -> np.ndarray:
    if name not in structure.node_sets:
        raise StructureError(
            f"{argument}: structure {structure.name!r} has no node set {name!r} (has {sorted(structure.node_sets)})"
        )
    nodes = np.asarray(structure.node_sets[name], dtype=np.int64)
    if nodes.size == 0:
        raise StructureError(f"{argument}: node set {name!r} of structure {structure.name!r} is empty")
    return nodes


def _check_struts(structure: Structure) -> None:
    other = np.flatnonzero(structure.members.kind != MEMBER_KINDS.index("strut"))
    if other.size:
        kinds = sorted({MEMBER_KINDS[k] for k in structure.members.kind[other]})
        raise StructureError(
            f"members[{int(other[0])}].kind: the axial cantilever takes struts only; structure "
            f"{structure.name!r} has {other.size} other members ({', '.join(kinds)})"
        )


def cantilever(
    structure: Structure,
    *,
    load_N: float = 1.0,
    root: str = "root",
    tip: str = "tip",
    length_m: float | None = None,
) -> CantileverResult:
    """Static tip deflection of ``structure`` clamped at node set ``root`` under a total load
    ``load_N`` along −z split over node set ``tip`` (see the module docstring for the equations)."""
    load = check_positive("load_N", load_N)
    _check_struts(structure)
    clamp, loaded = _node_set(structure, root, "root"), _node_set(structure, tip, "tip")
    shared = np.intersect1d(clamp, loaded)
    if shared.size:
        raise StructureError(f"root, tip: node {int(shared[0])} is in both node sets {root!r} and {tip!r}")
    p = structure.positions_m
    length = float(np.mean(p[loaded, 0]) - np.mean(p[clamp, 0])) if length_m is None else length_m
    length = check_positive("length_m", length)
    members = structure.members
    K = stiffness_matrix(p, members.nodes, members.stiffness_N_m).tocsc()
    fixed = np.zeros(3 * structure.n_nodes, dtype=bool)
    fixed[(3 * clamp[:, None] + np.arange(3)).ravel()] = True
    free = np.flatnonzero(~fixed)
    f = np.zeros(3 * structure.n_nodes)
    f[3 * loaded + 2] = -load / loaded.size
    u = np.zeros_like(f)
    with warnings.catch_warnings():
        warnings.simplefilter("error", MatrixRankWarning)
        try:
            u[free] = spsolve(K[free][:, free], f[free])
        except MatrixRankWarning:
            u[:] = np.nan
    delta = -float(np.mean(u[3 * loaded + 2]))
    if not np.all(np.isfinite(u)) or not delta > 0:
        raise StructureError(
            f"root: structure {structure.name!r} clamped at node set {root!r} is a mechanism "
            f"(singular stiffness, tip deflection {delta!r})"
        )
    return CantileverResult(
        load_N=load, length_m=length, tip_deflection_m=delta, EI_eff_Nm2=load * length**3 / (3.0 * delta)
    )


def calibrate_axial_rigidity(
    structure_factory: Callable[..., Structure],
    EI_Nm2: float,
    *,
    load_N: float = 1.0,
    root: str = "root",
    tip: str = "tip",
    length_m: float | None = None,
    reference_EA_N: float = 1.0,
) -> float:
    """Axial rigidity ``EA`` [N] at which ``structure_factory(EA_N=EA)`` has the cantilever
    bending stiffness ``EI_Nm2`` [N m²] (one sparse solve, see the module docstring).

    ``structure_factory`` takes the keyword ``EA_N`` and must make every member's EA proportional
    to it (checked on a second build at ``2 · reference_EA_N``), e.g.
    ``functools.partial(octet_plate, units=8, side_m=10.0, total_mass_kg=5.0)``.
    """
    target = check_positive("EI_Nm2", EI_Nm2)
    reference = check_positive("reference_EA_N", reference_EA_N)
    built = structure_factory(EA_N=reference)
    doubled = structure_factory(EA_N=2.0 * reference)
    same_shape = built.positions_m.shape == doubled.positions_m.shape and len(built.members) == len(doubled.members)
    if not same_shape or not np.allclose(
        doubled.members.EA_N, 2.0 * built.members.EA_N, rtol=PROPORTIONAL_RTOL, atol=0.0
    ):
        raise StructureError(
            "structure_factory: the members' EA must be proportional to the EA_N argument "
            f"(the structure built at EA_N={2.0 * reference!r} is not twice the one at {reference!r})"
        )
    result = cantilever(built, load_N=load_N, root=root, tip=tip, length_m=length_m)
    return reference * target / result.EI_eff_Nm2
