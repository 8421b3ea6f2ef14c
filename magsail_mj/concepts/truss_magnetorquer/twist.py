r"""Twist of the truss: a Kirchhoff plate's twist mode, the lattice's low modes, and the
``stiffness.twist = "plate"`` variant that gives the lattice the plate's twist frequency.

Only the bending stiffness ``EI`` of the lattice is calibrated (against the cantilever beam); its
torsional stiffness follows from the strut pattern. The lowest elastic mode of the free 75 m
lattice is a twist (the anticlastic saddle ``w ∝ x y``) at 0.0357 rad/s, below what a plate of
the same ``EI`` has.

Plate. An isotropic Kirchhoff plate of side ``d``, areal density ``ρ_A = M/d²`` [kg/m²] and
flexural rigidity per unit width ``D = EI/d`` [N m] (the plate in cylindrical bending has the
beam stiffness ``EI`` over its width ``d``) stores

    U = ½ ∫ D [ (w_xx + w_yy)² − 2(1 − ν)(w_xx w_yy − w_xy²) ] dA

(the twisting rigidity per unit width is ``D(1 − ν)``: a uniform twist ``w = θ' x y`` carries
the twisting moment ``D(1 − ν) θ'`` per unit width). Its free–free twist mode (odd in ``x`` and in
``y``) is found by the Rayleigh–Ritz method over the odd–odd monomials ``x^p y^q`` (``p, q`` odd,
up to degree ``2 n_terms − 1`` each), whose energy and mass integrals over the square are exact;
the frequency parameter ``λ = ω d² √(ρ_A / D)`` converges from above to Leissa's 13.468 for
``ν = 0.3`` (the single term ``x y`` gives ``√(288 (1 − ν))`` = 14.20).

Lattice modes. ``K φ = ω² M φ`` with the lattice's linear stiffness (assembled at the undeformed
nodes) and the diagonal particle mass matrix, the lowest ``n`` pairs by sparse shift-invert
Lanczos (``scipy.sparse.linalg.eigsh``), mass-normalised (``φᵀ M φ = 1``); the six rigid modes
come first. The same problem as :func:`magsail_mj.lattice.modes.lattice_modes` solves densely.

Twist shape. The Kirchhoff twist field of the lattice (body frame, origin at the centre, ``z``
from the mid-plane): ``u = −z y, v = −z x, w = x y``. Its mass-weighted share of a mode or a
displacement ``δ`` is ``(δᵀ M t)² / ((δᵀ M δ)(tᵀ M t))`` ∈ [0, 1].

Variant. ``stiffness.twist = "plate"`` multiplies the spring constant of every face diagonal by a
ratio ``ρ`` relative to the cube edges, then scales all struts together so that the cantilever
gives ``EI`` again (the calibration of the shipped lattice), and chooses ``ρ`` (Brent's method on
``log ρ``) so that the lattice's first twist mode has the plate's frequency. Both conditions are
free of ``d``, ``EI`` and ``M`` for uniform particle masses, so ``ρ`` and the scale depend only on
the lattice's size, its diagonal pattern and ``ν``; they are found once on a unit lattice.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import linalg, sparse
from scipy.optimize import brentq
from scipy.sparse.linalg import eigsh

from magsail_mj.lattice.geometry import (
    STRUT_KINDS,
    Lattice,
    axial_rigidity_from_EI,
    make_lattice,
    stiffness_matrix,
)
from magsail_mj.lattice.properties import cantilever_linear

__all__ = [
    "plate_twist_lambda",
    "plate_twist_omega",
    "LowModes",
    "low_modes",
    "twist_field",
    "twist_shares",
    "first_twist_mode",
    "TwistScaling",
    "twist_scaling",
    "diagonal_struts",
]

DIAGONAL_KINDS = ("xy_diagonal", "xz_diagonal", "yz_diagonal")


def _moment(n: int) -> float:
    """∫ s^n ds over s ∈ [−½, ½] (0 for odd n)."""
    return 0.0 if n % 2 else 2.0 * 0.5 ** (n + 1) / (n + 1)


def plate_twist_lambda(nu: float, *, n_terms: int = 5) -> float:
    """Frequency parameter ``λ = ω d² √(ρ_A/D)`` of the free square Kirchhoff plate's twist mode.

    Rayleigh–Ritz over ``x^p y^q`` with ``p, q ∈ {1, 3, …, 2 n_terms − 1}`` on the unit square
    centred at the origin (module docstring); ``nu`` is Poisson's ratio, in (−1, 0.5].
    """
    if not -1.0 < nu <= 0.5:
        raise ValueError(f"nu: Poisson's ratio must be in (-1, 0.5], got {nu!r}")
    if int(n_terms) != n_terms or n_terms < 1:
        raise ValueError(f"n_terms: must be an integer >= 1, got {n_terms!r}")
    powers = [(p, q) for p in range(1, 2 * n_terms, 2) for q in range(1, 2 * n_terms, 2)]

    def d2(p, q, ax):
        """Second derivative of x^p y^q: (coefficient, p', q') along ``ax`` = 'xx', 'yy', 'xy'."""
        if ax == "xx":
            return p * (p - 1), p - 2, q
        if ax == "yy":
            return q * (q - 1), p, q - 2
        return p * q, p - 1, q - 1

    def integral(a, b):
        ca, pa, qa = a
        cb, pb, qb = b
        if ca == 0 or cb == 0 or pa < 0 or qa < 0 or pb < 0 or qb < 0:
            return 0.0
        return ca * cb * _moment(pa + pb) * _moment(qa + qb)

    n = len(powers)
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    for i, (p1, q1) in enumerate(powers):
        for j, (p2, q2) in enumerate(powers):
            xx = integral(d2(p1, q1, "xx"), d2(p2, q2, "xx"))
            yy = integral(d2(p1, q1, "yy"), d2(p2, q2, "yy"))
            xy = integral(d2(p1, q1, "xx"), d2(p2, q2, "yy")) + integral(d2(p1, q1, "yy"), d2(p2, q2, "xx"))
            tw = integral(d2(p1, q1, "xy"), d2(p2, q2, "xy"))
            K[i, j] = xx + yy + nu * xy + 2.0 * (1.0 - nu) * tw
            M[i, j] = _moment(p1 + p2) * _moment(q1 + q2)
    lam2 = linalg.eigh(K, M, eigvals_only=True)[0]
    return float(np.sqrt(lam2))


def plate_twist_omega(*, EI_Nm2: float, total_kg: float, side_m: float, nu: float = 0.3) -> float:
    """Twist-mode frequency [rad/s] of the free square plate with ``D = EI/d``, ``ρ_A = M/d²``:
    ``ω = λ(ν) √(D / (ρ_A d⁴)) = λ(ν) √(EI / (M d³))``."""
    for name, v in (("EI_Nm2", EI_Nm2), ("total_kg", total_kg), ("side_m", side_m)):
        if not v > 0:
            raise ValueError(f"{name}: must be > 0, got {v!r}")
    return plate_twist_lambda(nu) * float(np.sqrt(EI_Nm2 / (total_kg * side_m**3)))


@dataclass(frozen=True)
class LowModes:
    """The lowest modes of a free lattice: ``omega`` (n,) [rad/s] ascending (the first
    ``n_rigid`` set to 0), ``phi`` (3 n_nodes, n) mass-normalised shapes, node-major
    ``(x0, y0, z0, x1, …)`` in the frame of the undeformed nodes [kg^-1/2]."""

    omega: np.ndarray
    phi: np.ndarray
    n_rigid: int

    def elastic(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        """``(omega, phi)`` of the first ``count`` elastic modes."""
        s = slice(self.n_rigid, self.n_rigid + count)
        return self.omega[s], self.phi[:, s]


def low_modes(
    nodes: np.ndarray, struts: np.ndarray, k: np.ndarray, masses: np.ndarray, *, n_elastic: int = 10, n_rigid: int = 6
) -> LowModes:
    """The ``n_rigid`` rigid and the lowest ``n_elastic`` elastic modes (module docstring).

    Shift-invert about ``σ = −10⁻⁶ ω_ref²`` (``ω_ref² = max k / mean m``), so the singular free
    stiffness is factorised safely; the rigid modes' round-off eigenvalues are clamped to 0. The
    Lanczos start vector is fixed, so equal inputs give bit-equal modes (within a repeated
    frequency the basis is one arbitrary but reproducible choice).
    """
    masses = np.asarray(masses, dtype=float)
    K = stiffness_matrix(np.asarray(nodes, dtype=float), np.asarray(struts), np.asarray(k, dtype=float)).tocsc()
    m3 = np.repeat(masses, 3)
    M = sparse.diags(m3).tocsc()
    scale = float(np.max(k)) / float(np.mean(masses))
    n = min(n_rigid + n_elastic, K.shape[0] - 1)
    v0 = np.random.default_rng(0).standard_normal(K.shape[0])  # fixed start: the same modes every call
    lam, phi = eigsh(K, k=n, M=M, sigma=-1e-6 * scale, which="LM", v0=v0)
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    phi = phi / np.sqrt(np.einsum("i,ij,ij->j", m3, phi, phi))[None, :]
    omega = np.sqrt(np.clip(lam, 0.0, None))
    omega[:n_rigid] = 0.0
    return LowModes(omega=omega, phi=phi, n_rigid=int(n_rigid))


def twist_field(nodes: np.ndarray) -> np.ndarray:
    """(3 n,) Kirchhoff twist displacement ``(−z y, −z x, x y)`` at ``nodes`` (about their centroid)."""
    p = np.asarray(nodes, dtype=float) - np.mean(nodes, axis=0)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    return np.column_stack([-z * y, -z * x, x * y]).ravel()


def twist_shares(vectors: np.ndarray, nodes: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """Mass-weighted share ``(δᵀ M t)² / ((δᵀ M δ)(tᵀ M t))`` of the twist field ``t`` in each
    column ``δ`` of ``vectors`` (3 n, K) (or one (3 n,) vector) → (K,) in [0, 1]."""
    v = np.asarray(vectors, dtype=float)
    v2 = v[:, None] if v.ndim == 1 else v
    m3 = np.repeat(np.asarray(masses, dtype=float), 3)
    t = twist_field(nodes)
    num = (t * m3) @ v2
    den = np.einsum("i,ij,ij->j", m3, v2, v2) * float((t * m3) @ t)
    return num**2 / np.where(den > 0, den, np.inf)


def first_twist_mode(
    modes: LowModes, nodes: np.ndarray, masses: np.ndarray, *, min_share: float = 0.5
) -> tuple[int, float]:
    """Column index and frequency [rad/s] of the lowest elastic mode whose twist share is at
    least ``min_share``; ValueError when none of the computed modes is one."""
    shares = twist_shares(modes.phi[:, modes.n_rigid :], nodes, masses)
    hit = np.flatnonzero(shares >= min_share)
    if not hit.size:
        raise ValueError(
            f"min_share: no computed elastic mode has a twist share >= {min_share} (largest {shares.max():.3f})"
        )
    col = modes.n_rigid + int(hit[0])
    return col, float(modes.omega[col])


def diagonal_struts(lattice: Lattice) -> np.ndarray:
    """Boolean (S,) mask of the face diagonals (top/bottom and vertical faces)."""
    return np.isin(lattice.kind, [STRUT_KINDS.index(k) for k in DIAGONAL_KINDS])


@dataclass(frozen=True)
class TwistScaling:
    """Spring constants of the ``"plate"`` twist variant: ``k_s = c · EA/l0_s · (ρ on face
    diagonals, 1 on edges)``. ``ratio`` is ρ, ``scale`` is c (after the cantilever calibration),
    ``omega_ratio_lattice`` the shipped calibrated lattice's twist frequency over the plate's."""

    ratio: float
    scale: float
    omega_ratio_lattice: float


def _unit_problem(units: int, diagonals: str):
    lat = make_lattice(units=units, side_m=float(units), diagonals=diagonals)
    EA = axial_rigidity_from_EI(1.0, nodes_per_side=lat.nodes_per_side, cube_edge_m=lat.cube_edge_m)
    masses = np.full(lat.n_nodes, 1.0 / lat.n_nodes)
    return lat, EA / lat.rest_length, masses


def _calibrated(lat: Lattice, k_formula: np.ndarray, ratio: float) -> tuple[np.ndarray, float]:
    """``k`` with the diagonals times ``ratio``, all scaled so the cantilever gives EI = 1."""
    k = np.where(diagonal_struts(lat), ratio, 1.0) * k_formula
    c = 1.0 / cantilever_linear(lat, k, load_N=1e-6).EI_eff_Nm2
    return c * k, c


@lru_cache(maxsize=16)
def twist_scaling(units: int, diagonals: str, nu: float) -> TwistScaling:
    """ρ and c of the ``"plate"`` variant for a lattice of ``units`` cubes per side (module
    docstring); the target is :func:`plate_twist_omega` of a unit plate (EI = 1, M = 1, d = units)."""
    lat, k_formula, masses = _unit_problem(units, diagonals)
    target = plate_twist_omega(EI_Nm2=1.0, total_kg=1.0, side_m=lat.side_m, nu=nu)

    def log_mismatch(log_ratio: float) -> float:
        k, _ = _calibrated(lat, k_formula, float(np.exp(log_ratio)))
        _, w = first_twist_mode(low_modes(lat.nodes, lat.struts, k, masses, n_elastic=6), lat.nodes, masses)
        return float(np.log(w / target))

    base = log_mismatch(0.0)
    lo, hi = (0.0, 1.0) if base < 0 else (-1.0, 0.0)
    f_lo, f_hi = log_mismatch(lo), log_mismatch(hi)
    for _ in range(8):
        if f_lo * f_hi <= 0:
            break
        lo, hi = (hi, hi + 2.0) if base < 0 else (lo - 2.0, lo)
        f_lo, f_hi = (f_hi, log_mismatch(hi)) if base < 0 else (log_mismatch(lo), f_lo)
    else:
        raise ValueError(
            f"stiffness.twist: no diagonal-to-edge ratio in e^[{lo:.0f}, {hi:.0f}] gives the plate's "
            f"twist frequency for units = {units}, diagonals = {diagonals!r}"
        )
    log_ratio = brentq(log_mismatch, lo, hi, xtol=1e-6)
    ratio = float(np.exp(log_ratio))
    _, c = _calibrated(lat, k_formula, ratio)
    return TwistScaling(ratio=ratio, scale=c, omega_ratio_lattice=float(np.exp(base)))
