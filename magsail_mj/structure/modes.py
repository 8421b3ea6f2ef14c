r"""Undamped modes of any structure: frequencies, M-orthonormal shapes, participation, shares.

Eigenproblem
    :math:`\mathbf K_r\boldsymbol\phi=\omega^2\mathbf M_r\boldsymbol\phi` of the reduced sparse
    matrices of :func:`magsail_mj.structure.assembly.assemble` (rigid parts and ``fixed_dofs``
    applied; a prestressed structure's tangent stiffness about the static equilibrium of its
    members' prestrain, the elastic stiffness plus the geometric stiffness of the members' axial
    forces there, :class:`~magsail_mj.structure.assembly.Prestress`, so that a free prestressed
    structure keeps its six rigid-body zero modes in any orientation). The lowest ``k`` pairs come
    from ``scipy.sparse.linalg.eigsh`` in shift-invert mode about a slightly negative shift ``σ``
    (default ``σ = −10⁻⁹ s``, ``s = max_i K_ii / M_ii`` over the coordinates with mass: the highest
    frequency scale of the model), so that ``K_r − σ M_r`` is factorised even when ``K_r`` is
    singular (a free structure) and the eigenvalues nearest ``σ`` are the lowest ``ω² ≥ 0``. ``K_r −
    σ M_r`` is symmetric positive definite: SuperLU factors it with diagonal pivots in the
    minimum-degree order of ``Aᵀ + A``. ``M_r`` may be singular (massless coordinates have infinite
    frequencies, never returned). Below 500 coordinates (``solver="auto"``) the dense LAPACK
    ``scipy.linalg.eigh(K_r, M_r)`` solves the whole problem instead (the shift-inverted pair ``M_r
    φ = ν (K_r − σ M_r) φ``, ``ω² = σ + 1/ν``, when ``M_r`` is singular).

Zero modes
    Rigid-body motions (six for a free, connected structure) and mechanisms have ``ω² = 0`` up to
    round-off; mode ``n`` counts as zero and its ``ω²`` is clamped to 0 when
    ``|ω²_n| ≤ zero_tol · ρ_n`` with ``ρ_n = |φ_n|ᵀ |K_r| |φ_n|`` (the Rayleigh quotient of the
    entries' absolute values: the scale at which round-off enters that mode's ``ω²``; default
    ``zero_tol = 10⁻¹²``: rigid modes measure ``~10⁻¹⁷`` (sparse) to ``~10⁻¹⁴`` (dense), the first
    elastic mode of a free boom of 100 beam elements ``10⁻⁷``, of 1 000 elements ``10⁻¹¹``, of the
    20 000-node lattice ``10⁻⁷``). ``eigenvalues`` keeps the unclamped values.

Participation (about the centre of mass, structure axes)
    With the unit rigid-body motions ``D_j`` (translations x, y, z, rotations about x, y, z through
    the centre of mass, :func:`~magsail_mj.structure.assembly.rigid_motions`, in the independent
    coordinates), the participation factor of mode ``n`` is ``Γ_nj = φ_nᵀ M_r D_j`` [kg^½ or
    kg^½ m], its effective modal mass ``Γ_nj²`` [kg or kg m²] and the fraction ``Γ_nj² / (D_jᵀ M_r
    D_j)``; over all modes the fractions sum to 1. In a free structure the rigid modes carry all
    of it; in a fixed one (a cantilever) the elastic modes do (for a uniform cantilever the first
    three bending modes' effective masses are 0.613, 0.188 and 0.065 of the beam's mass; the
    reference excludes the mass at the clamped nodes, so the fractions are a little larger).

Shares (:class:`ModeShares`)
    Per mode, the split of the translational motion (mass-weighted, ``Σ m_i |u_i|²`` of the lumped
    node masses; rotation dofs are not counted) into ``in_plane``, ``bending`` and ``twist``. The
    frame is the principal frame of the structure's inertia about its centre of mass: the normal
    ``n`` is the axis of the largest principal moment (the plate normal of a flat structure), the
    in-plane axes ``e1, e2`` the two others, smaller moment first; an axis pair of equal moments
    (within 10⁻⁶ relative, e.g. a square plate) is aligned with the structure axes instead (the
    structure axis most in the pair's plane first). With node coordinates ``(x, y)`` along
    ``e1, e2``: ``in_plane`` is the energy of ``(u·e1, u·e2)``; the out-of-plane displacement
    ``w = u·n`` is split into its four parity parts under the mirrors ``x → −x`` and ``y → −y``
    (``w_aa = (w − w∘X − w∘Y + w∘XY)/4`` etc., a mirror image being the node nearest to the mirrored
    position): ``twist`` is the part antisymmetric in both in-plane coordinates (``w ∝ x y``, a
    plate twisting about its in-plane axes), ``bending`` the three others (symmetric in one or both:
    bending about an in-plane axis, saddles, the rigid tilts). The out-of-plane energy is divided
    between them in the ratio of the parts' energies, so the three shares sum to 1 (a mode with no
    translation has all three 0). ``symmetric`` says whether every mirror image is within 10⁻⁶ of
    the structure's size of a node (exact parity parts; otherwise the nearest nodes stand in).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import linalg
from scipy.sparse.linalg import LinearOperator, eigsh, splu
from scipy.spatial import cKDTree

from magsail_mj.structure.assembly import Assembly, assemble
from magsail_mj.structure.model import Structure, StructureError

__all__ = [
    "DENSE_LIMIT",
    "RIGID_DIRECTIONS",
    "ModeShares",
    "Participation",
    "StructureModes",
    "mode_shares",
    "principal_frame",
    "structure_modes",
]

DENSE_LIMIT = 500
"""Models with fewer independent coordinates are solved densely by ``solver="auto"``."""
RIGID_DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
"""The rigid-body directions of the participation factors (translations, then rotations)."""
_SIGMA_REL = 1e-9
_INFINITE_REL = 1e-13
_DEGENERATE_REL = 1e-6
_MIRROR_REL = 1e-6


@dataclass(frozen=True)
class Participation:
    """Participation of the modes in the six rigid-body motions (module docstring).

    Attributes:
      factors: (k, 6) ``Γ_nj`` [kg^½ (translations), kg^½ m (rotations)].
      effective_mass: (k, 6) ``Γ_nj²`` [kg, kg m²].
      reference: (6,) ``D_jᵀ M_r D_j``: the mass [kg] and inertias about the centre of mass
        [kg m²] that can move (the constrained coordinates' mass excluded).
      fraction: (k, 6) ``effective_mass / reference`` (0 where the reference is 0).
    """

    factors: np.ndarray
    effective_mass: np.ndarray
    reference: np.ndarray
    fraction: np.ndarray


@dataclass(frozen=True)
class ModeShares:
    """In-plane / bending / twist split of each mode's translational motion (module docstring).

    Attributes:
      in_plane, bending, twist: (k,) fractions, summing to 1 per mode (0 for a mode without
        translation).
      axes: (3, 3) rows ``e1, e2, n`` in structure axes.
      symmetric: whether the structure is mirror-symmetric in ``e1`` and ``e2`` (exact parity split).
    """

    in_plane: np.ndarray
    bending: np.ndarray
    twist: np.ndarray
    axes: np.ndarray
    symmetric: bool


@dataclass(frozen=True)
class StructureModes:
    """The lowest modes of a structure (module docstring).

    Attributes:
      frequencies_Hz: (k,) ``ω / 2π`` ascending, zero modes clamped to 0 [Hz].
      eigenvalues: (k,) the computed ``ω²`` before clamping [rad²/s²].
      n_zero: number of zero modes (rigid-body and mechanism), the first ``n_zero``.
      shapes: (n_reduced, k) mode shapes in the independent coordinates, M-orthonormal
        (``shapesᵀ M_r shapes = I``) [kg^-½].
      participation: the rigid-body participation.
      share: the in-plane / bending / twist shares.
      assembly: the assembled matrices (``assembly.T @ shapes``: all dofs).
      solver: ``"sparse"`` or ``"dense"``.
      sigma: the shift used [rad²/s²].
      zero_tol: the relative tolerance of the zero modes.
    """

    frequencies_Hz: np.ndarray
    eigenvalues: np.ndarray
    n_zero: int
    shapes: np.ndarray
    participation: Participation
    share: ModeShares
    assembly: Assembly
    solver: str
    sigma: float
    zero_tol: float

    @property
    def omega_rad_s(self) -> np.ndarray:
        """(k,) circular frequencies [rad/s]."""
        return 2.0 * np.pi * self.frequencies_Hz

    def dof_shapes(self) -> np.ndarray:
        """(n_dof, k) the mode shapes at every dof (``T φ``; fixed dofs 0) [kg^-½]."""
        return np.asarray(self.assembly.T @ self.shapes)

    def node_translations(self) -> np.ndarray:
        """(k, n_nodes, 3) the translation of every node in each mode, structure axes [kg^-½]."""
        full = self.dof_shapes()
        trans = self.assembly.layout.translation_dofs()
        return np.moveaxis(full[trans], 2, 0)


#: eigenvalues within this fraction of the stiffest coordinate's ``K_ii / M_ii`` are round-off
#: (64 ε: the stiffness matrix's entries are known to ε of its largest)
ROUNDING_FLOOR = 64 * float(np.finfo(float).eps)


def _frequency_scale(assembly: Assembly) -> float:
    """``s = max K_ii / M_ii`` over the coordinates with mass [rad²/s²] (1 if none)."""
    k, m = assembly.K_r.diagonal(), assembly.M_r.diagonal()
    ratio = np.divide(k, m, out=np.zeros_like(k), where=m > 0)
    s = float(ratio.max(initial=0.0))
    return s if s > 0 else 1.0


def _dense(assembly: Assembly, k: int, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    K, M = assembly.K_r.toarray(), assembly.M_r.toarray()
    try:
        lam, phi = linalg.eigh(K, M, subset_by_index=[0, k - 1], check_finite=False)
    except linalg.LinAlgError:  # M singular: the shift-inverted pair, largest ν first
        n = K.shape[0]
        nu, phi = linalg.eigh(M, K - sigma * M, subset_by_index=[n - k, n - 1], check_finite=False)
        nu, phi = nu[::-1], phi[:, ::-1]
        # ν = 1/(ω² − σ) ≥ 1/(s + |σ|) ≈ 10⁻⁹ ν_max for a finite mode; massless directions give ν = 0
        finite = nu > _INFINITE_REL * nu[0]
        if not np.all(finite):
            raise ValueError(f"k: only {int(np.sum(finite))} finite-frequency modes exist, got k={k}") from None
        lam = sigma + 1.0 / nu
        phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, M @ phi))
    return lam, phi


def _shift_inverse(assembly: Assembly, sigma: float) -> LinearOperator:
    """``(K_r − σ M_r)⁻¹`` as an operator: SuperLU of the symmetric positive definite matrix with the
    minimum-degree ordering of ``Aᵀ + A`` and diagonal pivots (a sixth of the fill of the default
    column ordering on a lattice)."""
    A = (assembly.K_r - sigma * assembly.M_r).tocsc()
    try:
        lu = splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError as err:  # a zero pivot: a motion with neither stiffness nor mass
        raise StructureError(
            f"structure: K − σM (σ = {sigma:.3g}) cannot be factorised ({err}); some motion has neither "
            "stiffness nor mass"
        ) from None
    return LinearOperator(A.shape, matvec=lu.solve, dtype=float)


def _sparse(assembly: Assembly, k: int, sigma: float, tol: float) -> tuple[np.ndarray, np.ndarray]:
    K, M = assembly.K_r, assembly.M_r
    # rank M ≤ the coordinates with mass (a zero diagonal entry of a semi-definite M zeroes its row),
    # and only rank M frequencies are finite: the Krylov space cannot grow beyond them
    massive = int(np.count_nonzero(M.diagonal() > 0))
    if k > massive - 2:
        raise ValueError(
            f"k: {massive} coordinates carry mass, so the sparse solver finds at most {max(massive - 2, 0)} "
            f"modes, got k={k}; use solver='dense'"
        )
    ncv = min(K.shape[0] - 1, massive - 1, max(2 * k + 1, k + 20))
    lam, phi = eigsh(K, k=k, M=M, sigma=sigma, which="LM", ncv=ncv, tol=tol, OPinv=_shift_inverse(assembly, sigma))
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    # M-orthonormal (eigsh returns them so up to its tolerance; normalise exactly)
    phi = phi / np.sqrt(np.einsum("ij,ij->j", phi, np.asarray(M @ phi)))
    return lam, phi


def _zero_modes(assembly: Assembly, lam: np.ndarray, phi: np.ndarray, zero_tol: float) -> np.ndarray:
    """(k,) True for the modes with ``|ω²| ≤ zero_tol · |φ|ᵀ|K||φ|`` or below the rounding of the
    stiffest coordinate, ``|ω²| ≤`` :data:`ROUNDING_FLOOR` ``· max K_ii / M_ii`` (a mode of nodes
    that no member holds — a membrane's interior without membrane stiffness — has ``|K||φ| = 0``
    and an eigenvalue of pure round-off of either sign)."""
    abs_K = abs(assembly.K_r)
    a = np.abs(phi)
    rho = np.einsum("ij,ij->j", a, np.asarray(abs_K @ a))
    return (np.abs(lam) <= zero_tol * rho) | (np.abs(lam) <= ROUNDING_FLOOR * _frequency_scale(assembly))


def _participation(assembly: Assembly, phi: np.ndarray) -> Participation:
    D = assembly.rigid_r
    MD = np.asarray(assembly.M_r @ D)
    factors = phi.T @ MD
    reference = np.einsum("ij,ij->j", D, MD)
    effective = factors**2
    fraction = np.divide(effective, reference, out=np.zeros_like(effective), where=reference > 0)
    return Participation(factors=factors, effective_mass=effective, reference=reference, fraction=fraction)


def principal_frame(inertia_kg_m2: np.ndarray) -> np.ndarray:
    """(3, 3) rows ``e1, e2, n``: principal axes by rising moment, right-handed; an axis pair (or
    triple) of equal moments (10⁻⁶ relative) aligned with the structure axes (module docstring)."""
    moments, vectors = linalg.eigh(np.asarray(inertia_kg_m2, dtype=float))
    scale = max(float(np.abs(moments).max()), 1e-300)
    axes = vectors.T.copy()
    start = 0
    while start < 3:
        stop = start + 1
        while stop < 3 and moments[stop] - moments[start] <= _DEGENERATE_REL * scale:
            stop += 1
        if stop - start > 1:
            axes[start:stop] = _aligned_basis(vectors[:, start:stop])
        start = stop
    if np.dot(np.cross(axes[0], axes[1]), axes[2]) < 0:
        axes[2] = -axes[2]
    return axes


def _aligned_basis(basis: np.ndarray) -> np.ndarray:
    """Orthonormal rows spanning ``basis`` (3, c), taken from the structure axes' projections
    (the axis most in the subspace first; of axes equally far in, to 1e-9, the first: x, y, z)."""
    projector = basis @ basis.T
    chosen: list[np.ndarray] = []
    for _ in range(basis.shape[1]):
        candidates = projector @ np.eye(3)  # column j: structure axis j projected
        for c in chosen:
            candidates -= np.outer(c, c @ candidates)
        norms = np.linalg.norm(candidates, axis=0)
        # the first axis among those as far in as the most (to 1e-9): ties are not left to round-off
        j = int(np.flatnonzero(norms >= norms.max() - 1e-9)[0])
        chosen.append(candidates[:, j] / norms[j])
    return np.array(chosen)


def _mirrors(coords: np.ndarray) -> tuple[np.ndarray, bool]:
    """(3, n) nodes nearest to the mirror images ``x → −x``, ``y → −y`` and both; whether exact."""
    size = max(float(np.ptp(coords, axis=0).max(initial=0.0)), 1e-300)
    tree = cKDTree(coords)
    images = [coords * np.array(s) for s in ((-1, 1, 1), (1, -1, 1), (-1, -1, 1))]
    found = [tree.query(image) for image in images]
    exact = all(float(d.max(initial=0.0)) <= _MIRROR_REL * size for d, _ in found)
    return np.array([i for _, i in found]), exact


def mode_shares(structure: Structure, translations: np.ndarray) -> ModeShares:
    """Shares of node translations ``translations`` (k, n, 3) [any length unit] (module docstring)."""
    _, center, inertia = structure.mass_properties()
    axes = principal_frame(inertia)
    coords = (structure.positions_m - center) @ axes.T
    mirror, exact = _mirrors(coords)
    m = structure.lumped_masses()
    local = translations @ axes.T  # (k, n, 3) along e1, e2, n
    e_in = np.einsum("n,knc->k", m, local[:, :, :2] ** 2)
    w = local[:, :, 2]
    wx, wy, wxy = w[:, mirror[0]], w[:, mirror[1]], w[:, mirror[2]]
    parts = [w + wx + wy + wxy, w - wx + wy - wxy, w + wx - wy - wxy, w - wx - wy + wxy]  # ss, as, sa, aa
    energies = np.array([np.einsum("n,kn->k", m, (p / 4.0) ** 2) for p in parts])
    e_out = np.einsum("n,kn->k", m, w**2)
    total = e_in + e_out
    parity = energies.sum(axis=0)
    twist_part = np.divide(energies[3], parity, out=np.zeros_like(parity), where=parity > 0)
    out_share = np.divide(e_out, total, out=np.zeros_like(total), where=total > 0)
    in_share = np.divide(e_in, total, out=np.zeros_like(total), where=total > 0)
    return ModeShares(
        in_plane=in_share,
        bending=out_share * (1.0 - twist_part),
        twist=out_share * twist_part,
        axes=axes,
        symmetric=exact,
    )


def structure_modes(
    structure: Structure,
    *,
    k: int = 20,
    sigma: float | None = None,
    mass: Literal["lumped", "consistent"] = "lumped",
    solver: Literal["auto", "sparse", "dense"] = "auto",
    zero_tol: float = 1e-12,
    tol: float = 0.0,
    assembly: Assembly | None = None,
) -> StructureModes:
    """The ``k`` lowest modes of ``structure`` (module docstring).

    Args:
      structure: the structure (rigid parts and ``fixed_dofs`` applied).
      k: number of modes (at most the number of independent coordinates).
      sigma: shift of the sparse and the singular-mass dense solve [rad²/s²], < 0 (default
        ``−10⁻⁹ max K_ii/M_ii``).
      mass: the beam mass model (:data:`magsail_mj.structure.assembly.MASS_MODELS`).
      solver: ``"auto"`` (dense below :data:`DENSE_LIMIT` coordinates), ``"sparse"`` or ``"dense"``.
      zero_tol: relative tolerance of the zero modes (module docstring).
      tol: ``eigsh`` relative accuracy of the eigenvalues (0: machine precision).
      assembly: ``assemble(structure, mass=mass)`` when already made.

    Raises:
      ValueError: a bad option (named), or a structure that cannot be assembled
        (:class:`~magsail_mj.structure.model.StructureError`).
    """
    if assembly is None:
        assembly = assemble(structure, mass=mass)
    elif assembly.mass != mass:
        raise ValueError(f"assembly: made with mass={assembly.mass!r}, not {mass!r}")
    n = assembly.n_dof
    if int(k) != k or not 1 <= k <= n:
        raise ValueError(f"k: must be an integer in 1..{n} (the independent coordinates), got {k!r}")
    if solver not in ("auto", "sparse", "dense"):
        raise ValueError(f"solver: must be 'auto', 'sparse' or 'dense', got {solver!r}")
    if not (np.isfinite(zero_tol) and zero_tol >= 0):
        raise ValueError(f"zero_tol: must be finite and >= 0, got {zero_tol!r}")
    shift = -_SIGMA_REL * _frequency_scale(assembly) if sigma is None else float(sigma)
    if not (np.isfinite(shift) and shift < 0):
        raise ValueError(f"sigma: must be finite and < 0, got {sigma!r}")
    use = solver if solver != "auto" else ("dense" if n < DENSE_LIMIT else "sparse")
    if use == "sparse" and k >= n - 1:
        raise ValueError(f"k: the sparse solver finds at most {n - 2} of {n} modes, got k={k}; use solver='dense'")
    lam, phi = _dense(assembly, int(k), shift) if use == "dense" else _sparse(assembly, int(k), shift, tol)
    zero = _zero_modes(assembly, lam, phi, zero_tol)
    omega2 = np.where(zero, 0.0, lam)
    if np.any(omega2 < 0):
        bad = int(np.argmin(omega2))
        raise ValueError(
            f"structure: mode {bad} has ω² = {omega2[bad]:.6g} rad²/s² < 0 beyond round-off; K is not positive "
            "semi-definite"
        )
    trans = np.moveaxis(np.asarray(assembly.T @ phi)[assembly.layout.translation_dofs()], 2, 0)
    return StructureModes(
        frequencies_Hz=np.sqrt(omega2) / (2.0 * np.pi),
        eigenvalues=lam,
        n_zero=int(zero.sum()),
        shapes=phi,
        participation=_participation(assembly, phi),
        share=mode_shares(structure, trans),
        assembly=assembly,
        solver=use,
        sigma=shift,
        zero_tol=float(zero_tol),
    )
