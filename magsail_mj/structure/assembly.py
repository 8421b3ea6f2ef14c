r"""Sparse stiffness and mass matrices of a :class:`~magsail_mj.structure.model.Structure`.

Everything is assembled from index arrays (one row per member, no Python loop over members) into
``scipy.sparse`` COO triplets summed into CSR; no dense ``n_dof × n_dof`` matrix is ever formed.

Degrees of freedom (:class:`DofLayout`)
    A node touched by a beam has 6 dofs, its displacement ``(u_x, u_y, u_z)`` [m] and its small
    rotation ``(θ_x, θ_y, θ_z)`` [rad], structure axes; every other node has the 3 translations.
    Dofs are numbered node by node (node-major), translations first.

Struts and cables
    Axial springs between the node centres, linearised about the reference positions: a member of
    unit vector ``ê`` (from its first to its second node at ``positions_m``) and ``k = EA / l0``
    adds ``k ê êᵀ`` to the two diagonal 3 × 3 translation blocks and ``−k ê êᵀ`` to the two
    off-diagonal ones. A cable is included at its rest state as a taut tension spring (the
    small-vibration model of a cable that stays in tension; a cable slack at the reference,
    ``l < l0``, adds nothing). A member with an axial force ``N`` (below, "Prestress") adds the
    geometric stiffness ``(N / l)(I − ê êᵀ)`` in the same block pattern, the transverse stiffness
    a string under tension has.

Beams (3-D Euler–Bernoulli frame elements)
    Local axes: ``x`` along the member from its first to its second node; ``y`` (section axis 1)
    the part of the member's ``orientation`` vector ``v`` perpendicular to ``x`` (Nastran's
    CBAR/CBEAM ``v``); ``z = x × y``. A zero ``orientation`` takes for ``v`` the structure axis
    least aligned with the member (the first of the smallest ``|x_i|``: a member along the
    structure ``x`` axis has local ``y, z`` = structure ``y, z``). As in Nastran, ``EI_Nm2[:, 0]``
    (``E I1``) is the bending stiffness in plane 1 (the local ``x–y`` plane: deflection ``v`` along
    ``y``, rotation ``θ_z = dv/dx``) and ``EI_Nm2[:, 1]`` (``E I2``) in plane 2 (deflection ``w``
    along ``z``, rotation ``θ_y = −dw/dx``). With ``l = l0`` the local 12 × 12 stiffness, dofs
    ``(u, v, w, θ_x, θ_y, θ_z)`` of the first node then the second, holds ``EA/l [1 −1; −1 1]`` on
    ``u``, ``GJ/l [1 −1; −1 1]`` on ``θ_x`` and the Hermite bending block
    ``EI/l³ [[12, 6l, −12, 6l], [6l, 4l², −6l, 2l²], [−12, −6l, 12, −6l], [6l, 2l², −6l, 4l²]]`` on
    ``(v₁, θ_z1, v₂, θ_z2)`` (and with the signs of the ``θ_y`` rows and columns flipped on
    ``(w₁, θ_y1, w₂, θ_y2)``); it is rotated into structure axes by ``Λᵀ K Λ``, ``Λ`` the
    block-diagonal of four copies of the direction cosine matrix ``R`` (rows: local ``x, y, z``).
    Shear deformation is neglected. A beam with an axial force ``N`` (tension positive) adds the
    consistent geometric stiffness of a beam-column, ``N/(30 l) [[36, 3l, −36, 3l], [3l, 4l², −3l,
    −l²], [−36, −3l, 36, −3l], [3l, −l², −3l, 4l²]]`` on each bending plane (signs as above) and
    ``N I_p/(A l) [1 −1; −1 1]`` on ``θ_x`` (``I_p/A = (EI1 + EI2)/EA``); its shear forces and
    bending moments add no geometric stiffness.

Prestress (:class:`Prestress`, :func:`prestress_equilibrium`)
    A member whose rest length ``l0`` differs from its node distance ``l`` carries the axial force
    ``N0 = EA (l / l0 − 1)`` at the reference (:func:`reference_forces`; a prestrained cable net, a
    tensioned membrane, a beam or strut made short or long). These forces are in general not in
    equilibrium at the reference positions (a tensioned net pulls the booms that hold it, which
    the booms' compression has to balance), and a tangent stiffness assembled from them is not
    invariant under rigid rotation (a free prestressed structure then shows fewer than six zero
    modes). :func:`assemble` therefore first solves the linear prestress equilibrium
    ``K_e u = −r0`` in the independent coordinates: ``K_e`` the elastic stiffness (no geometric
    term), ``r0`` the members' internal forces at the reference (``−N0 ê`` at a member's first
    node, ``+N0 ê`` at its second). ``K_e`` is singular (rigid-body motions, mechanisms such as
    a flat net's out-of-plane motion), and ``r0``, a sum of member forces, lies in its range; the
    solve is conjugate gradients preconditioned by the factor of ``K_e + σ D`` (``D`` the
    diagonal of ``K_e``, ``σ = 10⁻¹⁰``) to the relative residual :data:`PRESTRESS_RTOL`. In a free
    structure (no ``fixed_dofs``) the rigid-body part of ``u`` is removed (``Dᵀ M u = 0`` for the
    six rigid motions ``D``). The axial force of every member at the equilibrium,
    ``N = N0 + (EA / l0) ê · (u_b − u_a)`` (struts, taut cables and beams: the booms' compression
    under a net's pull), then gives the geometric stiffness, and ``K = K_e + K_g(N)`` is the
    tangent stiffness about the equilibrium, which the modes use. A rigid part holding nodes at
    arms ``r_i`` from its centre on which the members pull (internal forces ``g_i`` at
    equilibrium) adds the geometric stiffness of its finite rotation, ``Σ_i sym(g_i r_iᵀ) −
    (g_i · r_i) I``, at its rotation coordinates. With these terms a rigid rotation of the free
    structure stores no energy: six zero modes, to the rounding of the solve, whenever the beams
    carry axial force alone at the equilibrium (their end shears and moments have no geometric
    term). The model is linear: the cables keep their reference state (taut or slack), and a
    taut cable whose force at the equilibrium is negative stays in the model with that force
    (:attr:`Prestress.compressed_cables` lists them; a real cable would go slack, and the
    structure's own equilibrium is then a finite distance from its reference shape). A structure
    without prestrain (every ``N0 = 0``) skips the solve: ``K = K_e``.

Mass (``mass=`` :data:`MASS_MODELS`)
    ``"lumped"``: the translational masses of :meth:`Structure.lumped_masses` (point masses, half of
    every member's ``ρA l0`` at each end, panel shares) on the diagonal, and at each end of a beam
    a rotational inertia, in local axes ``diag(ρI_p l/2, ρA l³/78, ρA l³/78)`` — the HRZ
    (Hinton–Rock–Zienkiewicz) diagonal scaling of the consistent matrix below, rotated into
    structure axes (a 3 × 3 block at the node's rotation dofs).
    ``"consistent"``: the same, except that every beam carries its standard consistent 12 × 12 mass
    matrix instead of its lumped translational and rotational terms: ``ρA l/6 [2 1; 1 2]`` on ``u``,
    ``ρI_p l/6 [2 1; 1 2]`` on ``θ_x`` and ``ρA l/420 [[156, 22l, 54, −13l], [22l, 4l², 13l, −3l²],
    [54, 13l, 156, −22l], [−13l, −3l², −22l, 4l²]]`` on each bending plane (the rotary inertia of
    the section in bending is neglected, as in Euler–Bernoulli theory). Struts and cables stay
    lumped in both models. The polar mass moment per length is ``ρI_p = ρA (EI1 + EI2) / EA``
    (a homogeneous section: ``I_p = I1 + I2`` and ``E`` cancels).

Rigid parts and constraints (:func:`assemble`)
    The nodes a rigid part holds move with it: a part has six master coordinates, the translation
    ``u_c`` of its centre ``center_m`` and its small rotation ``θ``, and a held node moves by
    ``u_i = u_c + θ × (p_i − c)`` (a held node with rotation dofs turns by ``θ``). The sparse
    transformation ``T`` (``n_dof × n_reduced``) maps the independent coordinates ``q`` (the dofs
    of the nodes no part holds, then six per part) to all dofs, ``u = T q``; the reduced matrices
    are ``K_r = Tᵀ K T`` and ``M_r = Tᵀ M T + M_parts``, ``M_parts = diag(m I₃, I_c)`` of each part
    at its master coordinates (its own mass and inertia about its centre). ``fixed_dofs`` then
    remove coordinates: a fixed component of a free node drops its column of ``T``; fixed
    components of held nodes restrict the part's masters to the null space of those rows of ``T``
    (so a part with three non-collinear fixed nodes is clamped). A rotation constraint on a node
    without rotation dofs constrains nothing.

Units: SI (``K`` in N/m, N, N m for the translation and rotation dofs; ``M`` in kg, kg m, kg m²).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, sparse
from scipy.sparse.linalg import LinearOperator, cg, splu

from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError

__all__ = [
    "MASS_MODELS",
    "PRESTRESS_RTOL",
    "Assembly",
    "DofLayout",
    "Prestress",
    "assemble",
    "beam_frames",
    "dof_layout",
    "mass_matrix",
    "prestress_equilibrium",
    "reference_forces",
    "rigid_motions",
    "stiffness_matrix",
]

MASS_MODELS = ("lumped", "consistent")
"""Beam mass models of :func:`mass_matrix` (module docstring)."""

_BEAM = MEMBER_KINDS.index("beam")
_CABLE = MEMBER_KINDS.index("cable")
#: the largest relative residual of the prestress equilibrium (:class:`Prestress`): the conjugate
#: gradients reach 10⁻¹³ on the 100 m sail; 10⁻¹⁰ leaves the forces exact to far below their use
PRESTRESS_RTOL = 1e-10
# the shift of the equilibrium solve's preconditioner K + σ D (relative to each diagonal entry)
_PRESTRESS_SHIFT = 1e-10
_PRESTRESS_MAX_ITER = 500
#: a reference strain this small is the rounding of a rest length computed from the node distance
_STRAIN_ROUNDING = 1e-12
# HRZ lumped rotational inertia per ρA l³: the consistent diagonal 4 l²/420 scaled by the element
# mass over the translational diagonal's sum, ρA l / (2 · 156/420 ρA l): 4/312 = 1/78
_HRZ_ROTATION = 1.0 / 78.0
# Hermite bending blocks of a unit-length element, dofs (w1, θ1, w2, θ2), θ = dw/dx; entries are
# polynomials in l: stiffness EI/l³ · (A + B l + C l²), mass ρA l/420 · (A + B l + C l²).
_BEND_K = (
    np.array([[12, 0, -12, 0], [0, 0, 0, 0], [-12, 0, 12, 0], [0, 0, 0, 0]], float),
    np.array([[0, 6, 0, 6], [6, 0, -6, 0], [0, -6, 0, -6], [6, 0, -6, 0]], float),
    np.array([[0, 0, 0, 0], [0, 4, 0, 2], [0, 0, 0, 0], [0, 2, 0, 4]], float),
)
_BEND_M = (
    np.array([[156, 0, 54, 0], [0, 0, 0, 0], [54, 0, 156, 0], [0, 0, 0, 0]], float),
    np.array([[0, 22, 0, -13], [22, 0, 13, 0], [0, 13, 0, -22], [-13, 0, -22, 0]], float),
    np.array([[0, 0, 0, 0], [0, 4, 0, -3], [0, 0, 0, 0], [0, -3, 0, 4]], float),
)
_BEND_G = (
    np.array([[36, 0, -36, 0], [0, 0, 0, 0], [-36, 0, 36, 0], [0, 0, 0, 0]], float),
    np.array([[0, 3, 0, 3], [3, 0, -3, 0], [0, -3, 0, -3], [3, 0, -3, 0]], float),
    np.array([[0, 0, 0, 0], [0, 4, 0, -1], [0, 0, 0, 0], [0, -1, 0, 4]], float),
)
_PLANE1 = np.array([1, 5, 7, 11])  # (v1, θz1, v2, θz2): θz = dv/dx
_PLANE2 = np.array([2, 4, 8, 10])  # (w1, θy1, w2, θy2): θy = −dw/dx
_PLANE2_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


@dataclass(frozen=True)
class DofLayout:
    """Numbering of the dofs: node ``i`` owns ``first_dof[i] .. first_dof[i] + node_dofs[i] − 1``
    (translations x, y, z, then for 6-dof nodes rotations x, y, z).

    Attributes:
      node_dofs: (n,) 3 or 6.
      first_dof: (n,) index of the node's first dof.
      n_dof: number of dofs.
      dof_node: (n_dof,) the node of each dof.
      dof_component: (n_dof,) the component of each dof (0–2 translations, 3–5 rotations).
    """

    node_dofs: np.ndarray
    first_dof: np.ndarray
    n_dof: int
    dof_node: np.ndarray
    dof_component: np.ndarray

    def translation_dofs(self, nodes: np.ndarray | None = None) -> np.ndarray:
        """(k, 3) dof indices of the translations of ``nodes`` (default: all nodes)."""
        first = self.first_dof if nodes is None else self.first_dof[np.asarray(nodes, dtype=np.int64)]
        return first[:, None] + np.arange(3)

    def rotation_dofs(self, nodes: np.ndarray) -> np.ndarray:
        """(k, 3) dof indices of the rotations of ``nodes`` (nodes with 6 dofs only)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        if np.any(self.node_dofs[nodes] != 6):
            bad = nodes[self.node_dofs[nodes] != 6]
            raise ValueError(f"nodes: {bad[:5].tolist()} have no rotation dofs")
        return self.first_dof[nodes][:, None] + 3 + np.arange(3)


def dof_layout(structure: Structure) -> DofLayout:
    """The dof numbering of ``structure``: 6 dofs at nodes touched by a beam, else 3."""
    n = structure.n_nodes
    members = structure.members
    node_dofs = np.full(n, 3, dtype=np.int64)
    node_dofs[members.nodes[members.kind == _BEAM].ravel()] = 6
    first = np.concatenate([[0], np.cumsum(node_dofs)[:-1]]).astype(np.int64)
    n_dof = int(node_dofs.sum())
    dof_node = np.repeat(np.arange(n), node_dofs)
    dof_component = np.arange(n_dof) - first[dof_node]
    return DofLayout(node_dofs=node_dofs, first_dof=first, n_dof=n_dof, dof_node=dof_node, dof_component=dof_component)


def _check_members(structure: Structure) -> None:
    members = structure.members
    n = structure.n_nodes
    problems = []
    bad = np.flatnonzero((members.nodes < 0).any(axis=1) | (members.nodes >= n).any(axis=1))
    problems += [f"members[{i}].nodes: {members.nodes[i].tolist()} is outside 0..{n - 1}" for i in bad[:10]]
    if not problems:
        p = structure.positions_m
        length = np.linalg.norm(p[members.nodes[:, 1]] - p[members.nodes[:, 0]], axis=1)
        bad = np.flatnonzero(~(length > 0))
        problems += [f"members[{i}].nodes: both ends at {p[members.nodes[i, 0]].tolist()} m" for i in bad[:10]]
    bad = np.flatnonzero(~(members.rest_length_m > 0))
    problems += [f"members[{i}].rest_length_m: must be > 0, got {members.rest_length_m[i]!r}" for i in bad[:10]]
    for name in ("EA_N", "EI_Nm2", "GJ_Nm2", "linear_density_kg_m"):
        values = getattr(members, name).reshape(len(members), -1)
        bad = np.flatnonzero(~np.all(np.isfinite(values) & (values >= 0), axis=1))
        problems += [f"members[{i}].{name}: must be finite and >= 0, got {values[i].tolist()}" for i in bad[:10]]
    if problems:
        raise StructureError(problems)


def beam_frames(structure: Structure, members: np.ndarray) -> np.ndarray:
    """(m, 3, 3) direction cosine matrices of ``members``: rows are the local ``x, y, z`` axes in
    structure axes (module docstring: ``x`` along the member, ``y`` from its ``orientation``)."""
    idx = np.asarray(members, dtype=np.int64)
    table = structure.members
    p = structure.positions_m
    ends = table.nodes[idx]
    x = p[ends[:, 1]] - p[ends[:, 0]]
    x = x / np.linalg.norm(x, axis=1, keepdims=True)
    v = np.array(table.orientation[idx], dtype=float)
    default = ~np.any(v != 0.0, axis=1)
    v[default] = np.eye(3)[np.argmin(np.abs(x[default]), axis=1)]
    y = v - np.einsum("ij,ij->i", v, x)[:, None] * x
    norm = np.linalg.norm(y, axis=1)
    bad = np.flatnonzero(~(norm > 1e-9 * np.linalg.norm(v, axis=1)))
    if bad.size:
        raise StructureError(
            [
                f"members[{idx[i]}].orientation: {table.orientation[idx[i]].tolist()} is parallel to the member axis "
                f"{x[i].tolist()}"
                for i in bad[:10]
            ]
        )
    y = y / norm[:, None]
    return np.stack([x, y, np.cross(x, y)], axis=1)


def _coo(rows: np.ndarray, cols: np.ndarray, vals: np.ndarray, n: int) -> sparse.csr_matrix:
    """Sum triplets into an ``n × n`` CSR matrix (explicit zeros dropped)."""
    matrix = sparse.coo_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n)).tocsr()
    matrix.eliminate_zeros()
    return matrix


def _element_triplets(dofs: np.ndarray, blocks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and values of element matrices ``blocks`` (m, d, d) at ``dofs`` (m, d)."""
    rows = np.broadcast_to(dofs[:, :, None], blocks.shape)
    cols = np.broadcast_to(dofs[:, None, :], blocks.shape)
    return rows, cols, blocks


def reference_forces(structure: Structure) -> np.ndarray:
    """(m,) axial force of every member at the reference positions, ``N0 = EA (l / l0 − 1)`` with
    ``l`` the node distance [N] (tension positive; a slack cable, ``l < l0``, carries 0; a strain
    within 10⁻¹² of 0 is the rounding of a rest length computed from ``l`` and counts as 0)."""
    return _reference_state(structure)[0]


def _reference_state(structure: Structure) -> tuple[np.ndarray, np.ndarray]:
    """(m,) the reference axial forces of :func:`reference_forces` and (m,) the slack cables."""
    table = structure.members
    p = structure.positions_m
    length = np.linalg.norm(p[table.nodes[:, 1]] - p[table.nodes[:, 0]], axis=1)
    strain = length / table.rest_length_m - 1.0
    strain = np.where(np.abs(strain) <= _STRAIN_ROUNDING, 0.0, strain)  # l0 computed from l
    slack = (table.kind == _CABLE) & (strain < 0)
    return np.where(slack, 0.0, table.EA_N * strain), slack


def _directions(structure: Structure, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors ``ê`` (s, 3) from the first to the second node and node distances ``l`` (s,)."""
    ends = structure.members.nodes[members]
    p = structure.positions_m
    d = p[ends[:, 1]] - p[ends[:, 0]]
    length = np.linalg.norm(d, axis=1)
    return d / length[:, None], length


def _axial_blocks(
    structure: Structure, layout: DofLayout, members: np.ndarray, force_N: np.ndarray, taut: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Dofs (s, 6) and global stiffness blocks (s, 6, 6) of axial springs: ``k ê êᵀ`` where
    ``taut`` plus the geometric stiffness ``(N / l)(I − ê êᵀ)`` of the axial forces ``force_N``."""
    table = structure.members
    ends = table.nodes[members]
    e, length = _directions(structure, members)
    k = np.where(taut, table.stiffness_N_m[members], 0.0)
    outer = k[:, None, None] * e[:, :, None] * e[:, None, :]
    outer += (force_N / length)[:, None, None] * (np.eye(3)[None] - e[:, :, None] * e[:, None, :])
    sign = np.array([[1.0, -1.0], [-1.0, 1.0]])
    blocks = (sign[None, :, None, :, None] * outer[:, None, :, None, :]).reshape(-1, 6, 6)
    dofs = np.concatenate([layout.translation_dofs(ends[:, 0]), layout.translation_dofs(ends[:, 1])], axis=1)
    return dofs, blocks


def _beam_dofs(layout: DofLayout, ends: np.ndarray) -> np.ndarray:
    """(m, 12) dofs of beams: the six of the first node, then the six of the second."""
    first = layout.first_dof[ends]  # (m, 2)
    return (first[:, :, None] + np.arange(6)).reshape(-1, 12)


def _fill_bending(
    local: np.ndarray,
    dofs: np.ndarray,
    scale: np.ndarray,
    l: np.ndarray,
    terms: tuple[np.ndarray, np.ndarray, np.ndarray],
    sign: np.ndarray | None = None,
) -> None:
    """Add ``scale · (A + B l + C l²)`` (per element) at ``dofs`` of ``local`` (m, 12, 12)."""
    block = scale[:, None, None] * (terms[0] + l[:, None, None] * terms[1] + (l * l)[:, None, None] * terms[2])
    if sign is not None:
        block = block * np.outer(sign, sign)
    local[:, dofs[:, None], dofs[None, :]] += block


def _pair(local: np.ndarray, a: int, b: int, diag: np.ndarray, off: np.ndarray) -> None:
    """Add the 2 × 2 block ``[[diag, off], [off, diag]]`` at local dofs ``(a, b)``."""
    local[:, a, a] += diag
    local[:, b, b] += diag
    local[:, a, b] += off
    local[:, b, a] += off


def _to_global(local: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """``Λᵀ local Λ`` with ``Λ`` = blockdiag(R, R, R, R) (m, 12, 12)."""
    m = local.shape[0]
    blocks = local.reshape(m, 4, 3, 4, 3)
    out = np.einsum("mpi,mapbq,mqj->maibj", frames, blocks, frames, optimize=True)
    return out.reshape(m, 12, 12)


def _beam_stiffness(structure: Structure, beams: np.ndarray, force_N: np.ndarray | None = None) -> np.ndarray:
    """(m, 12, 12) global stiffness of ``beams`` (module docstring), with the geometric stiffness
    of the axial forces ``force_N`` (m,) when given ("Prestress")."""
    table = structure.members
    l = table.rest_length_m[beams]
    local = np.zeros((beams.size, 12, 12))
    _pair(local, 0, 6, table.EA_N[beams] / l, -table.EA_N[beams] / l)
    _pair(local, 3, 9, table.GJ_Nm2[beams] / l, -table.GJ_Nm2[beams] / l)
    _fill_bending(local, _PLANE1, table.EI_Nm2[beams, 0] / l**3, l, _BEND_K)
    _fill_bending(local, _PLANE2, table.EI_Nm2[beams, 1] / l**3, l, _BEND_K, _PLANE2_SIGN)
    if force_N is not None:
        # the beam-column's consistent geometric stiffness N/(30 l) [[36, 3l, −36, 3l], ...] on each
        # bending plane and the Wagner term N I_p/(A l) on the twist, I_p/A = (EI1 + EI2)/EA
        _fill_bending(local, _PLANE1, force_N / (30.0 * l), l, _BEND_G)
        _fill_bending(local, _PLANE2, force_N / (30.0 * l), l, _BEND_G, _PLANE2_SIGN)
        EA = table.EA_N[beams]
        polar = np.divide(table.EI_Nm2[beams].sum(axis=1), EA, out=np.zeros(beams.size), where=EA > 0)
        _pair(local, 3, 9, force_N * polar / l, -force_N * polar / l)
    return _to_global(local, beam_frames(structure, beams))


def _polar_density(structure: Structure, beams: np.ndarray) -> np.ndarray:
    """``ρI_p = ρA (EI1 + EI2) / EA`` per beam [kg m] (0 where EA = 0)."""
    table = structure.members
    EA = table.EA_N[beams]
    ratio = np.divide(table.EI_Nm2[beams].sum(axis=1), EA, out=np.zeros(beams.size), where=EA > 0)
    return table.linear_density_kg_m[beams] * ratio


def _beam_consistent_mass(structure: Structure, beams: np.ndarray) -> np.ndarray:
    """(m, 12, 12) global consistent mass of ``beams`` (module docstring)."""
    table = structure.members
    l = table.rest_length_m[beams]
    rho_A = table.linear_density_kg_m[beams]
    rho_Ip = _polar_density(structure, beams)
    local = np.zeros((beams.size, 12, 12))
    _pair(local, 0, 6, rho_A * l / 3.0, rho_A * l / 6.0)
    _pair(local, 3, 9, rho_Ip * l / 3.0, rho_Ip * l / 6.0)
    _fill_bending(local, _PLANE1, rho_A * l / 420.0, l, _BEND_M)
    _fill_bending(local, _PLANE2, rho_A * l / 420.0, l, _BEND_M, _PLANE2_SIGN)
    return _to_global(local, beam_frames(structure, beams))


def _beam_rotary_lumped(structure: Structure, beams: np.ndarray) -> np.ndarray:
    """(m, 3, 3) HRZ rotational inertia of each beam end, structure axes [kg m²]."""
    table = structure.members
    l = table.rest_length_m[beams]
    rho_A = table.linear_density_kg_m[beams]
    transverse = _HRZ_ROTATION * rho_A * l**3
    diag = np.stack([0.5 * _polar_density(structure, beams) * l, transverse, transverse], axis=1)
    frames = beam_frames(structure, beams)
    return np.einsum("mpi,mp,mpj->mij", frames, diag, frames)


def stiffness_matrix(
    structure: Structure,
    layout: DofLayout | None = None,
    *,
    force_N: np.ndarray | None = None,
    slack: np.ndarray | None = None,
) -> sparse.csr_matrix:
    """Sparse stiffness ``K`` (``n_dof × n_dof`` CSR) of all members (module docstring): the
    elastic stiffness of the members, less the cables in ``slack`` (m,) (default: the cables slack
    at the reference), plus the geometric stiffness of the members' axial forces ``force_N`` (m,)
    [N] (default none: the elastic stiffness alone). :func:`assemble` gives the forces of the
    prestress equilibrium ("Prestress")."""
    _check_members(structure)
    layout = dof_layout(structure) if layout is None else layout
    table = structure.members
    m = len(table)
    if slack is None:
        slack = _reference_state(structure)[1]
    force = np.zeros(m) if force_N is None else np.asarray(force_N, dtype=float)
    if force.shape != (m,) or not np.all(np.isfinite(force)):
        raise ValueError(f"force_N: must be {m} finite axial forces, got shape {force.shape}")
    beams = np.flatnonzero(table.kind == _BEAM)
    axial = np.flatnonzero(table.kind != _BEAM)
    parts = [_element_triplets(*_axial_blocks(structure, layout, axial, force[axial], ~np.asarray(slack)[axial]))]
    if beams.size:
        blocks = _beam_stiffness(structure, beams, None if force_N is None else force[beams])
        parts.append(_element_triplets(_beam_dofs(layout, table.nodes[beams]), blocks))
    rows, cols, vals = (np.concatenate([np.ravel(p[i]) for p in parts]) for i in range(3))
    return _coo(rows, cols, vals, layout.n_dof)


def mass_matrix(structure: Structure, layout: DofLayout | None = None, *, mass: str = "lumped") -> sparse.csr_matrix:
    """Sparse mass ``M`` (``n_dof × n_dof`` CSR) of the nodes and members (rigid parts excluded:
    :func:`assemble` adds them at their master coordinates); ``mass`` one of :data:`MASS_MODELS`."""
    if mass not in MASS_MODELS:
        raise ValueError(f"mass: must be one of {MASS_MODELS}, got {mass!r}")
    _check_members(structure)
    layout = dof_layout(structure) if layout is None else layout
    table = structure.members
    beams = np.flatnonzero(table.kind == _BEAM)
    node_mass = structure.lumped_masses()
    ends = table.nodes[beams]
    parts = []
    if mass == "consistent" and beams.size:
        half = 0.5 * table.linear_density_kg_m[beams] * table.rest_length_m[beams]
        np.subtract.at(node_mass, ends.ravel(), np.repeat(half, 2))  # the beams' share becomes consistent
        parts.append(_element_triplets(_beam_dofs(layout, ends), _beam_consistent_mass(structure, beams)))
    elif beams.size:
        rotary = _beam_rotary_lumped(structure, beams)
        for end in (0, 1):
            rot = layout.rotation_dofs(ends[:, end])
            parts.append(_element_triplets(rot, rotary))
    trans = layout.translation_dofs()
    diag = np.repeat(node_mass, 3)
    parts.append((trans.ravel(), trans.ravel(), diag))
    rows, cols, vals = (np.concatenate([np.ravel(p[i]) for p in parts]) for i in range(3))
    return _coo(rows, cols, vals, layout.n_dof)


def rigid_motions(structure: Structure, layout: DofLayout, center_m: np.ndarray) -> np.ndarray:
    """(n_dof, 6) unit rigid-body motions of all dofs: translations along x, y, z [m/m] and small
    rotations about the axes through ``center_m`` [m/rad at translation dofs, rad/rad at rotation
    dofs], ``u_i = e_j × (p_i − center_m)``."""
    D = np.zeros((layout.n_dof, 6))
    trans = layout.translation_dofs()
    r = structure.positions_m - np.asarray(center_m, dtype=float)
    for j in range(3):
        D[trans[:, j], j] = 1.0
        D[trans, 3 + j] = np.cross(np.eye(3)[j], r)
    rotating = np.flatnonzero(layout.node_dofs == 6)
    if rotating.size:
        rot = layout.rotation_dofs(rotating)
        for j in range(3):
            D[rot[:, j], 3 + j] = 1.0
    return D


@dataclass(frozen=True)
class Prestress:
    """The static equilibrium of the members' initial forces (module docstring, "Prestress").

    Attributes:
      reference_force_N: (m,) axial force of each member at the reference positions ``N0``
        (:func:`reference_forces`) [N], tension positive.
      force_N: (m,) axial force at the equilibrium ``N`` [N] (0 for the cables slack at the
        reference; a cable may end in compression, ``compressed_cables``).
      displacement: (n_dof,) the equilibrium's displacement from the reference positions ``u``
        [m at translations, rad at rotations] (no rigid-body part in a free structure).
      slack: (m,) the cables slack at the reference (their stiffness left out).
      residual: ``‖K_e u + r0‖ / max(‖r0‖, ‖|K_e| |u|‖)`` (∞-norms) of the reduced equations.
      iterations: conjugate-gradient iterations of the solve (0 when no member is prestrained).
      compressed_cables: indices of the cables taut at the reference and in compression at the
        equilibrium (the linear model keeps their stiffness and force; a real cable would go
        slack there, so the reference shape is then far from the structure's own equilibrium).
    """

    reference_force_N: np.ndarray
    force_N: np.ndarray
    displacement: np.ndarray
    slack: np.ndarray
    residual: float
    iterations: int
    compressed_cables: np.ndarray


@dataclass(frozen=True)
class Assembly:
    """The assembled structure (module docstring).

    Attributes:
      layout: the dof numbering.
      K, M: (n_dof, n_dof) CSR stiffness and mass of the nodes and members.
      T: (n_dof, n_reduced) CSR map of the independent coordinates to all dofs, ``u = T q``
        (rigid parts and ``fixed_dofs`` applied).
      K_r, M_r: (n_reduced, n_reduced) CSR reduced stiffness ``Tᵀ K T`` and mass (with the rigid
        parts' own mass and inertia).
      rigid_r: (n_reduced, 6) the rigid-body motions about ``center_m`` (x, y, z translations and
        rotations, :func:`rigid_motions`) in the independent coordinates (least squares where
        constraints forbid them).
      center_m: (3,) centre of mass [m].
      mass: the mass model.
      prestress: the static equilibrium of the members' initial forces ("Prestress"); ``K`` and
        ``K_r`` are the tangent stiffness about it.
    """

    layout: DofLayout
    K: sparse.csr_matrix
    M: sparse.csr_matrix
    T: sparse.csr_matrix
    K_r: sparse.csr_matrix
    M_r: sparse.csr_matrix
    rigid_r: np.ndarray
    center_m: np.ndarray
    mass: str
    prestress: Prestress

    @property
    def n_dof(self) -> int:
        """Number of independent coordinates (the size of the eigenproblem)."""
        return int(self.K_r.shape[0])


def _held_nodes(structure: Structure) -> tuple[np.ndarray, np.ndarray]:
    """Nodes held by rigid parts and the index of each one's part; a node in two parts is refused."""
    n = structure.n_nodes
    nodes = [np.asarray(part.nodes, dtype=np.int64).ravel() for part in structure.rigid_parts]
    held = np.concatenate(nodes) if nodes else np.zeros(0, dtype=np.int64)
    owner = np.repeat(np.arange(len(nodes)), [a.size for a in nodes]).astype(np.int64)
    problems = []
    for j, part in enumerate(structure.rigid_parts):
        bad = nodes[j][(nodes[j] < 0) | (nodes[j] >= n)]
        problems += [f"rigid_parts[{j}] ({part.name!r}).nodes: node {b} is outside 0..{n - 1}" for b in bad[:10]]
    if problems:
        raise StructureError(problems)
    unique, first, counts = np.unique(held, return_index=True, return_counts=True)
    if np.any(counts > 1):
        twice = unique[counts > 1]
        parts = [structure.rigid_parts[o].name for o in owner[np.isin(held, twice)]]
        raise StructureError(f"rigid_parts.nodes: node {twice[0]} is held by more than one part ({parts[:2]})")
    return unique, owner[first]


def _constraint_basis(T0: sparse.csr_matrix, fixed_rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Orthonormal basis (6, r) of the master coordinates ``cols`` that leave ``fixed_rows`` at 0."""
    if fixed_rows.size == 0:
        return np.eye(cols.size)
    C = T0[fixed_rows][:, cols].toarray()
    return linalg.null_space(C, rcond=1e-12)


def _transformation(structure: Structure, layout: DofLayout) -> tuple[sparse.csr_matrix, sparse.csr_matrix, int]:
    """``T0`` (n_dof × n_r0: free node dofs, then six masters per part), the constraint basis
    ``S`` (n_r0 × n_r, orthonormal columns) and ``n_free`` (the free node dofs' count)."""
    held, owner = _held_nodes(structure)
    held_dof = np.zeros(layout.n_dof, dtype=bool)
    held_dof[np.isin(layout.dof_node, held)] = True
    free_dofs = np.flatnonzero(~held_dof)
    n_free = free_dofs.size
    n_r0 = n_free + 6 * len(structure.rigid_parts)
    rows, cols, vals = [free_dofs], [np.arange(n_free)], [np.ones(n_free)]
    if held.size:
        centers = np.array([part.center_m for part in structure.rigid_parts], dtype=float).reshape(-1, 3)
        master = n_free + 6 * owner
        trans = layout.translation_dofs(held)
        r = structure.positions_m[held] - centers[owner]
        zero = np.zeros_like(r[:, 0])
        # −[r]× θ: the translation of a held node per unit rotation of its part
        skew = np.stack(
            [
                np.stack([zero, r[:, 2], -r[:, 1]], axis=1),
                np.stack([-r[:, 2], zero, r[:, 0]], axis=1),
                np.stack([r[:, 1], -r[:, 0], zero], axis=1),
            ],
            axis=1,
        )
        rows += [trans.ravel(), np.repeat(trans, 3, axis=1).ravel()]
        cols += [(master[:, None] + np.arange(3)).ravel(), np.tile(master[:, None] + 3 + np.arange(3), 3).ravel()]
        vals += [np.ones(trans.size), skew.ravel()]
        rotating = layout.node_dofs[held] == 6
        if np.any(rotating):
            rot = layout.rotation_dofs(held[rotating])
            rows.append(rot.ravel())
            cols.append((master[rotating][:, None] + 3 + np.arange(3)).ravel())
            vals.append(np.ones(rot.size))
    T0 = sparse.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(layout.n_dof, n_r0)
    ).tocsr()
    S = _constraints(structure, layout, T0, held, owner, free_dofs)
    return T0, S, n_free


def _fixed_dof_mask(structure: Structure, layout: DofLayout) -> np.ndarray:
    """(n_dof,) True at the constrained dofs (``fixed_dofs``; rotations of 3-dof nodes ignored)."""
    fixed = np.asarray(structure.fixed_dofs, dtype=bool)
    if fixed.shape != (structure.n_nodes, 6):
        raise StructureError(f"fixed_dofs: expected shape ({structure.n_nodes}, 6), got {fixed.shape}")
    return fixed[layout.dof_node, layout.dof_component]


def _constraints(
    structure: Structure,
    layout: DofLayout,
    T0: sparse.csr_matrix,
    held: np.ndarray,
    owner: np.ndarray,
    free_dofs: np.ndarray,
) -> sparse.csr_matrix:
    """The constraint basis ``S`` of :func:`_transformation`."""
    fixed = _fixed_dof_mask(structure, layout)
    n_free = free_dofs.size
    keep = np.flatnonzero(~fixed[free_dofs])
    rows, cols, vals = [keep], [np.arange(keep.size)], [np.ones(keep.size)]
    col = keep.size
    held_fixed = np.flatnonzero(fixed & np.isin(layout.dof_node, held))
    part_of_dof = np.full(structure.n_nodes, -1, dtype=np.int64)
    part_of_dof[held] = owner
    for j in range(len(structure.rigid_parts)):
        masters = n_free + 6 * j + np.arange(6)
        basis = _constraint_basis(T0, held_fixed[part_of_dof[layout.dof_node[held_fixed]] == j], masters)
        r = basis.shape[1]
        rows.append(np.repeat(masters, r))
        cols.append(np.tile(col + np.arange(r), 6))
        vals.append(basis.ravel())
        col += r
    n_r0 = T0.shape[1]
    return sparse.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n_r0, col)
    ).tocsr()


def _part_mass(structure: Structure, n_free: int, n_r0: int) -> sparse.csr_matrix:
    """The rigid parts' own mass ``diag(m I₃, I_c)`` at their master coordinates."""
    rows, cols, vals = [], [], []
    for j, part in enumerate(structure.rigid_parts):
        base = n_free + 6 * j
        block = np.zeros((6, 6))
        block[:3, :3] = part.mass_kg * np.eye(3)
        block[3:, 3:] = np.asarray(part.inertia_kg_m2, dtype=float)
        idx = base + np.arange(6)
        rows.append(np.repeat(idx, 6))
        cols.append(np.tile(idx, 6))
        vals.append(block.ravel())
    if not rows:
        return sparse.csr_matrix((n_r0, n_r0))
    return _coo(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), n_r0)


def _rigid_reduced(structure: Structure, layout: DofLayout, n_free: int, center_m: np.ndarray) -> np.ndarray:
    """(n_r0, 6) rigid-body motions in the unconstrained independent coordinates."""
    full = rigid_motions(structure, layout, center_m)
    held, _ = _held_nodes(structure)
    free = np.flatnonzero(~np.isin(layout.dof_node, held))
    out = [full[free]]
    for part in structure.rigid_parts:
        block = np.zeros((6, 6))
        block[:3, :3] = np.eye(3)
        block[3:, 3:] = np.eye(3)
        d = np.asarray(part.center_m, dtype=float) - center_m
        block[:3, 3:] = np.cross(np.eye(3), d).T  # column j: e_j × d
        out.append(block)
    return np.concatenate(out)


def _check_parts(structure: Structure) -> None:
    problems = []
    for j, part in enumerate(structure.rigid_parts):
        inertia = np.asarray(part.inertia_kg_m2, dtype=float)
        if not (np.isfinite(part.mass_kg) and part.mass_kg >= 0):
            problems.append(f"rigid_parts[{j}] ({part.name!r}).mass_kg: must be finite and >= 0, got {part.mass_kg!r}")
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
            problems.append(f"rigid_parts[{j}] ({part.name!r}).inertia_kg_m2: must be a finite 3 × 3 matrix")
        if np.asarray(part.center_m).shape != (3,):
            problems.append(f"rigid_parts[{j}] ({part.name!r}).center_m: must have 3 components")
    if problems:
        raise StructureError(problems)


def _internal_forces(structure: Structure, layout: DofLayout, force_N: np.ndarray) -> np.ndarray:
    """(n_dof,) the members' internal forces ``r`` of the axial forces ``force_N`` (m,) along the
    reference directions: ``−N ê`` at the first node's translations, ``+N ê`` at the second (the
    gradient of the strain energy; the force on the nodes is ``−r``)."""
    e, _ = _directions(structure, np.arange(len(structure.members)))
    ends = structure.members.nodes
    r = np.zeros(layout.n_dof)
    np.add.at(r, layout.translation_dofs(ends[:, 0]), -force_N[:, None] * e)
    np.add.at(r, layout.translation_dofs(ends[:, 1]), force_N[:, None] * e)
    return r


def _singular_solve(K: sparse.csr_matrix, b: np.ndarray) -> tuple[np.ndarray, float, int]:
    """A solution of the consistent singular system ``K q = b`` (K symmetric positive
    semi-definite): conjugate gradients preconditioned by the factor of ``K + σ D`` (``D`` the
    diagonal of ``K``, its largest entry where it is 0; ``σ`` = :data:`_PRESTRESS_SHIFT`); the
    solution, its relative residual and the iterations."""
    d = K.diagonal()
    D = np.where(d > 0, d, float(d.max(initial=0.0)) or 1.0)
    A = (K + sparse.diags(_PRESTRESS_SHIFT * D)).tocsc()
    lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    count = [0]

    def step(_: np.ndarray) -> None:
        count[0] += 1

    preconditioner = LinearOperator(A.shape, matvec=lu.solve, dtype=float)
    q, _ = cg(K, b, rtol=0.1 * PRESTRESS_RTOL, atol=0.0, maxiter=_PRESTRESS_MAX_ITER, M=preconditioner, callback=step)
    scale = max(float(np.abs(b).max()), float((abs(K) @ np.abs(q)).max()), 1e-300)
    return q, float(np.abs(b - K @ q).max()) / scale, count[0]


def prestress_equilibrium(
    structure: Structure, layout: DofLayout, T: sparse.csr_matrix, rigid: np.ndarray, M_r: sparse.csr_matrix
) -> Prestress:
    """The static equilibrium of the members' reference forces (module docstring, "Prestress") in
    the independent coordinates ``u = T q``; ``rigid`` (n_reduced, 6) the rigid-body motions and
    ``M_r`` the reduced mass, with which a free structure's displacement is made M-orthogonal to
    the rigid-body motions (its centre of mass stays and it does not turn on average).

    Raises:
      StructureError: the equilibrium equations have no solution to :data:`PRESTRESS_RTOL` (a
        prestrained member that no stiffness holds).
    """
    table = structure.members
    force0, slack = _reference_state(structure)
    if not np.any(force0):
        none = np.zeros(0, dtype=np.int64)
        return Prestress(force0, np.zeros(len(table)), np.zeros(layout.n_dof), slack, 0.0, 0, none)
    K = (T.T @ stiffness_matrix(structure, layout, slack=slack) @ T).tocsr()
    q, residual, iterations = _singular_solve(0.5 * (K + K.T), -(T.T @ _internal_forces(structure, layout, force0)))
    if not residual <= PRESTRESS_RTOL:
        raise StructureError(
            f"members: the prestrained members' forces have no static equilibrium (relative residual "
            f"{residual:.3g} > {PRESTRESS_RTOL:g}); some prestrained member is held by no stiffness"
        )
    if not np.any(np.asarray(structure.fixed_dofs, dtype=bool)):
        MD = np.asarray(M_r @ rigid)
        q = q - rigid @ linalg.lstsq(rigid.T @ MD, MD.T @ q, cond=1e-12)[0]  # no rigid-body part
    u = np.asarray(T @ q)
    e, _ = _directions(structure, np.arange(len(table)))
    trans = layout.translation_dofs(table.nodes.ravel()).reshape(-1, 2, 3)
    stretch = np.einsum("ij,ij->i", e, u[trans[:, 1]] - u[trans[:, 0]])
    force = np.where(slack, 0.0, force0 + table.stiffness_N_m * stretch)
    compressed = np.flatnonzero((table.kind == _CABLE) & ~slack & (force < 0))
    return Prestress(force0, force, u, slack, residual, iterations, compressed)


def _part_geometric(
    structure: Structure, layout: DofLayout, internal: np.ndarray, n_free: int, n_r0: int
) -> sparse.csr_matrix:
    """The rigid parts' geometric stiffness at their rotation masters (module docstring,
    "Prestress"): ``Σ_i sym(g_i r_iᵀ) − (g_i · r_i) I`` over the held nodes, ``g_i`` the members'
    internal force at node ``i`` (``internal``, n_dof) and ``r_i`` its arm from the part's centre."""
    rows, cols, vals = [], [], []
    for j, part in enumerate(structure.rigid_parts):
        held = np.asarray(part.nodes, dtype=np.int64).ravel()
        g = internal[layout.translation_dofs(held)]
        r = structure.positions_m[held] - np.asarray(part.center_m, dtype=float)
        gr = np.einsum("ni,nj->ij", g, r)
        block = 0.5 * (gr + gr.T) - np.trace(gr) * np.eye(3)
        idx = n_free + 6 * j + 3 + np.arange(3)
        rows.append(np.repeat(idx, 3))
        cols.append(np.tile(idx, 3))
        vals.append(block.ravel())
    if not rows:
        return sparse.csr_matrix((n_r0, n_r0))
    return _coo(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), n_r0)


def assemble(structure: Structure, *, mass: str = "lumped") -> Assembly:
    """Stiffness, mass, rigid-part transformation and constraints of ``structure`` (module docstring),
    the stiffness about the prestress equilibrium.

    Raises:
      StructureError: a member, rigid part or constraint that cannot be assembled (named), an
        independent coordinate with neither stiffness nor mass (the node named), or a prestress
        without equilibrium.
      ValueError: ``mass`` is not one of :data:`MASS_MODELS`.
    """
    _check_parts(structure)
    layout = dof_layout(structure)
    M = mass_matrix(structure, layout, mass=mass)
    T0, S, n_free = _transformation(structure, layout)
    T = (T0 @ S).tocsr()
    _, center, _ = structure.mass_properties()
    rigid = np.asarray(S.T @ _rigid_reduced(structure, layout, n_free, center))
    M_r = (T.T @ M @ T + S.T @ _part_mass(structure, n_free, T0.shape[1]) @ S).tocsr()
    M_r = (0.5 * (M_r + M_r.T)).tocsr()
    prestress = prestress_equilibrium(structure, layout, T, rigid, M_r)
    K = stiffness_matrix(structure, layout, force_N=prestress.force_N, slack=prestress.slack)
    K_r = T.T @ K @ T
    if np.any(prestress.force_N) and structure.rigid_parts:
        K_e = stiffness_matrix(structure, layout, slack=prestress.slack)
        N0 = np.where(prestress.slack, 0.0, prestress.reference_force_N)
        internal = _internal_forces(structure, layout, N0) + K_e @ prestress.displacement
        K_r = K_r + S.T @ _part_geometric(structure, layout, internal, n_free, T0.shape[1]) @ S
    K_r = (0.5 * (K_r + K_r.T)).tocsr()
    assembly = Assembly(
        layout=layout,
        K=K,
        M=M,
        T=T,
        K_r=K_r,
        M_r=M_r,
        rigid_r=rigid,
        center_m=np.asarray(center),
        mass=mass,
        prestress=prestress,
    )
    _check_empty(assembly)
    return assembly


def _check_empty(assembly: Assembly) -> None:
    """Refuse independent coordinates with neither stiffness nor mass (the eigenproblem is singular)."""
    empty = np.flatnonzero((assembly.K_r.diagonal() == 0) & (assembly.M_r.diagonal() == 0))
    if empty.size == 0:
        return
    T = assembly.T.tocsc()
    layout = assembly.layout
    names = ("x", "y", "z", "rx", "ry", "rz")
    problems = []
    for j in empty[:10]:
        dofs = T.indices[T.indptr[j] : T.indptr[j + 1]]
        node = int(layout.dof_node[dofs[0]]) if dofs.size else -1
        comp = names[int(layout.dof_component[dofs[0]])] if dofs.size else "?"
        problems.append(
            f"nodes[{node}]: its {comp} coordinate has neither stiffness nor mass (no member or mass holds it); "
            "connect it, give it a mass or fix it in fixed_dofs"
        )
    raise StructureError(problems)
