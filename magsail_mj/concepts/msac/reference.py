r"""MSAC reference models: the paper's lumped formula (corrected) and the exact planar model.

Vedant & Allison 2019, Eqs. 1–7, and our exact reduced-order model.
All quantities SI; angles about world Z, positive counter-clockwise.

Lumped model (paper Eqs. 1, 6, 7, with our sign correction)
-------------------------------------------------------------------------
With the panel length frozen, ``I_sat ψ̇ + I_p φ̇ = 0``; adding the extended stroke
(``φa → φb`` at ``I_e``) and the contracted stroke (``φb → φa`` at ``I_c``) gives

.. math::
    θ_γ = \frac{I_e - I_c}{I_{sat}}\,(φ_a - φ_b), \qquad ω_γ ≈ θ_γ / Δt .

**Our correction of Eqs. 1–7.** The printed derivation mixes magnitude and signed notations; the
formula is used here with the *signed* stroke ``φa − φb`` (a symmetric ±10° motion gives a
non-zero result). ``I_e``, ``I_c`` are totals over all wings that move together (two wings:
twice the per-wing values) and ``I_sat`` is the bus alone.

Exact planar reduced-order model
--------------------------------------------
Bus (MOI ``I_b`` about Z) with ``n = 2`` identical rigid wings arranged point-symmetrically
(wing 2 = wing 1 rotated 180° about Z, same joint values), so the system centre of mass stays
at the bus centre. Wing: mass ``m``, centroidal MOI ``I_cm`` about Z, hinge at distance ``r0``
from the bus centre, hinge-to-COM distance ``c = s + ℓ/2`` (rigid slide). Each hinge body (a
tiny placeholder inertial in MuJoCo, mass ``m_r``, MOI ``I_r``, centred on the hinge) is
included for an exact comparison with the MJCF. With ``α = ψ + φ`` and zero total angular
momentum,

.. math::
    ψ̇\,D(φ, s) = -\big[N_φ(φ, s)\,φ̇ + N_s(φ, s)\,ṡ\big],

    D   = I_b + n\big[I_{cm} + I_r + m_r r_0^2 + m(r_0^2 + c^2 + 2 r_0 c\cos φ)\big],

    N_φ = n\big[I_{cm} + I_r + m c^2 + m r_0 c \cos φ\big],\qquad
    N_s = n\,m\,r_0 \sin φ .

(For ``m_r = I_r = 0`` this is the massless-rod form.) ``D`` does not depend on ``ψ``, so
``dψ = A_φ dφ + A_s ds`` with the connection ``A = −N/D`` depending on the shape only: the
per-cycle rotation is the line integral ``∮ A·dq`` over the closed path in the ``(φ, s)``
plane, independent of the timing (time-reparametrisation invariance), and zero for a path
that retraces itself (reciprocal motion). :func:`exact_rotation_path` evaluates it segment by
segment with Gauss–Legendre quadrature; :func:`exact_rotation_samples` integrates it along a
sampled (e.g. simulated) shape trajectory; :func:`exact_rotation_ode` is the slow plain
time-domain reference (explicit RK4 over the prescribed trajectory) both are tested against.
As ``I_b → ∞`` with ``r0 = 0`` the exact result tends to the lumped one with
``I_e = I_cm + m c_e²``, ``I_c = I_cm + m c_c²`` summed over both wings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from magsail_mj.config import check_finite_fields
from magsail_mj.concepts.msac.cycle import CyclePath, cycle_state_scalar

__all__ = [
    "PlanarMsac",
    "WingInertias",
    "wing_inertias",
    "lumped_theta",
    "lumped_rate",
    "exact_rotation_path",
    "exact_rotation_samples",
    "exact_rotation_ode",
]


@dataclass(frozen=True)
class PlanarMsac:
    """Parameters of the exact planar model (see module docs).

    Attributes:
      bus_izz_kgm2: bus MOI ``I_b`` about Z [kg m²].
      wing_mass_kg: ``m`` [kg].
      wing_length_m: rest length ``ℓ`` [m] (hinge-to-COM distance ``c = s + ℓ/2``).
      wing_icm_kgm2: wing MOI about its own centre of mass, about Z, ``I_cm`` [kg m²]
        (``m(ℓ² + t²)/12`` for a uniform plate of thickness ``t`` in the plane of motion).
      hinge_offset_m: ``r0`` [m].
      n_wings: number of point-symmetric wings driven together (2 for the spacecraft).
      root_mass_kg, root_inertia_kgm2: hinge-body placeholder ``m_r``, ``I_r``.
    """

    bus_izz_kgm2: float
    wing_mass_kg: float
    wing_length_m: float
    wing_icm_kgm2: float
    hinge_offset_m: float
    n_wings: int = 2
    root_mass_kg: float = 0.0
    root_inertia_kgm2: float = 0.0

    def __post_init__(self) -> None:
        check_finite_fields(
            self,
            positive=("bus_izz_kgm2", "wing_mass_kg", "wing_length_m"),
            non_negative=("wing_icm_kgm2", "hinge_offset_m", "root_mass_kg", "root_inertia_kgm2"),
        )
        if int(self.n_wings) != self.n_wings or self.n_wings < 1:
            raise ValueError(f"n_wings: must be an integer >= 1, got {self.n_wings!r}")

    def with_(self, **changes: float) -> "PlanarMsac":
        """A copy with some parameters changed (keyword-only)."""
        return replace(self, **changes)

    # ---------------------------------------------------------------- the model
    def inertia_sum(self, phi: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Whole-system MOI about Z, ``D(φ, s)`` [kg m²] (module docs)."""
        phi, s = np.asarray(phi, float), np.asarray(s, float)
        m, r0, n = self.wing_mass_kg, self.hinge_offset_m, self.n_wings
        c = s + 0.5 * self.wing_length_m
        return self.bus_izz_kgm2 + n * (
            self.wing_icm_kgm2
            + self.root_inertia_kgm2
            + self.root_mass_kg * r0**2
            + m * (r0**2 + c * c + 2.0 * r0 * c * np.cos(phi))
        )

    def shape_momentum_coefficients(self, phi: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(N_φ, N_s)`` [kg m², kg m]: angular momentum of the shape motion per unit rate."""
        phi, s = np.asarray(phi, float), np.asarray(s, float)
        m, r0, n = self.wing_mass_kg, self.hinge_offset_m, self.n_wings
        c = s + 0.5 * self.wing_length_m
        n_phi = n * (self.wing_icm_kgm2 + self.root_inertia_kgm2 + m * c * c + m * r0 * c * np.cos(phi))
        n_s = n * m * r0 * np.sin(phi)
        return n_phi, n_s

    def connection(self, phi: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(A_φ, A_s) = −(N_φ, N_s)/D`` so that ``ψ̇ = A_φ φ̇ + A_s ṡ`` [1, 1/m]."""
        D = self.inertia_sum(phi, s)
        n_phi, n_s = self.shape_momentum_coefficients(phi, s)
        return -n_phi / D, -n_s / D

    def angular_momentum(self, *, phi, s, psi_dot, phi_dot, s_dot) -> np.ndarray:
        """Total angular momentum about Z, ``L = D ψ̇ + N_φ φ̇ + N_s ṡ`` [N m s]."""
        n_phi, n_s = self.shape_momentum_coefficients(phi, s)
        return self.inertia_sum(phi, s) * np.asarray(psi_dot) + n_phi * np.asarray(phi_dot) + n_s * np.asarray(s_dot)


@dataclass(frozen=True)
class WingInertias:
    """Per-wing MOI about Z [kg m²] at rest (``s = 0``), extended (``se``) and contracted (``sc``).

    ``*_hinge``: about the hinge, ``I_cm + m c²`` (the model's ``I_e``, ``I_c`` of Eq. 6);
    ``*_centre``: about the bus centre with the wing undeflected, ``I_cm + m (r0 + c)²``;
    ``e_stretch``/``c_stretch``: the paper's uniformly stretched panel ``m ℓ'²/3`` with
    ``ℓ' = ℓ + s`` ("extension model note").
    """

    rest_hinge: float
    e_hinge: float
    c_hinge: float
    rest_centre: float
    e_centre: float
    c_centre: float
    e_stretch: float
    c_stretch: float


def wing_inertias(model: PlanarMsac, *, s_e_m: float, s_c_m: float) -> WingInertias:
    """Per-wing inertias of ``model`` for slide values ``s_e_m``, ``s_c_m`` [m] (see class docs)."""
    m, l, icm, r0 = model.wing_mass_kg, model.wing_length_m, model.wing_icm_kgm2, model.hinge_offset_m
    hinge = lambda s: icm + m * (s + l / 2) ** 2  # noqa: E731
    centre = lambda s: icm + m * (r0 + s + l / 2) ** 2  # noqa: E731
    stretch = lambda s: m * (l + s) ** 2 / 3.0  # noqa: E731
    return WingInertias(
        rest_hinge=hinge(0.0),
        e_hinge=hinge(s_e_m),
        c_hinge=hinge(s_c_m),
        rest_centre=centre(0.0),
        e_centre=centre(s_e_m),
        c_centre=centre(s_c_m),
        e_stretch=stretch(s_e_m),
        c_stretch=stretch(s_c_m),
    )


def lumped_theta(*, I_e: float, I_c: float, I_sat: float, phi_a: float, phi_b: float) -> float:
    r"""Per-cycle rotation of the lumped model, ``θ_γ = (I_e − I_c)(φa − φb)/I_sat`` [rad].

    Paper Eq. (6) in our signed-stroke form (the printed derivation mixes magnitudes and
    signed angles). ``I_e``, ``I_c`` are the
    totals over the wings [kg m²]; ``I_sat`` the bus MOI [kg m²]; ``φa``, ``φb`` signed [rad].
    """
    if not I_sat > 0:
        raise ValueError(f"I_sat: must be > 0, got {I_sat!r}")
    return (I_e - I_c) * (phi_a - phi_b) / I_sat


def lumped_rate(*, I_e: float, I_c: float, I_sat: float, phi_a: float, phi_b: float, period_s: float) -> float:
    """Secular rate of the lumped model, paper Eq. (7): ``ω_γ = θ_γ/Δt`` [rad/s]."""
    if not period_s > 0:
        raise ValueError(f"period_s: must be > 0, got {period_s!r}")
    return lumped_theta(I_e=I_e, I_c=I_c, I_sat=I_sat, phi_a=phi_a, phi_b=phi_b) / period_s


def _gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(int(nodes))
    return 0.5 * (x + 1.0), 0.5 * w


def exact_rotation_path(model: PlanarMsac, waypoints: np.ndarray, *, nodes: int = 32) -> np.ndarray:
    r"""Per-segment bus rotations ``∫ A·dq`` along a polygonal shape path [rad].

    Segment ``j`` runs straight from ``waypoints[j]`` to ``waypoints[j+1]`` (``(φ, s)`` rows,
    [rad, m]); with ``q(λ) = P_j + λ ΔP``,
    ``θ_j = ∫₀¹ [A_φ(q) Δφ + A_s(q) Δs] dλ`` by ``nodes``-point Gauss–Legendre quadrature.
    The integrand is analytic in ``λ``; 32 nodes reproduce 64 nodes to round-off (tested).
    The per-cycle rotation is ``exact_rotation_path(...).sum()`` for a closed path.

    Args:
      model: the planar model.
      waypoints: (K+1, 2) path vertices.
      nodes: quadrature nodes per segment (>= 2).

    Returns:
      (K,) rotation of each segment [rad].
    """
    wp = np.asarray(waypoints, dtype=float)
    if wp.ndim != 2 or wp.shape[1] != 2 or wp.shape[0] < 2:
        raise ValueError(f"waypoints: expected shape (K+1, 2) with K >= 1, got {wp.shape}")
    if int(nodes) != nodes or nodes < 2:
        raise ValueError(f"nodes: must be an integer >= 2, got {nodes!r}")
    lam, w = _gauss_legendre(nodes)
    p0, dp = wp[:-1], np.diff(wp, axis=0)  # (K, 2)
    q = p0[:, None, :] + lam[None, :, None] * dp[:, None, :]  # (K, n, 2)
    a_phi, a_s = model.connection(q[..., 0], q[..., 1])  # (K, n)
    return (a_phi * dp[:, None, 0] + a_s * dp[:, None, 1]) @ w


def exact_rotation_samples(model: PlanarMsac, phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    r"""Bus rotation accumulated along a sampled shape trajectory [rad].

    ``ψ_k − ψ_0 = Σ_{i<k} A(q_{i+½})·(q_{i+1} − q_i)`` with the connection evaluated at the
    midpoint of each chord (second-order accurate in the sample spacing). Use it on a recorded
    (achieved) trajectory to separate tracking error from integration error.

    Args:
      phi, s: (T,) samples of ``φ`` [rad] and ``s`` [m] along the path, T >= 1.

    Returns:
      (T,) rotation relative to the first sample [rad].
    """
    phi, s = np.asarray(phi, dtype=float), np.asarray(s, dtype=float)
    if phi.ndim != 1 or phi.shape != s.shape or phi.size < 1:
        raise ValueError(f"phi, s: expected equal shapes (T,), got {phi.shape} and {s.shape}")
    a_phi, a_s = model.connection(0.5 * (phi[1:] + phi[:-1]), 0.5 * (s[1:] + s[:-1]))
    inc = a_phi * np.diff(phi) + a_s * np.diff(s)
    return np.concatenate([[0.0], np.cumsum(inc)])


def exact_rotation_ode(model: PlanarMsac, path: CyclePath, *, cycles: int = 1, steps_per_cycle: int = 4000) -> float:
    r"""Slow plain reference: integrate ``ψ̇ = A_φ φ̇ + A_s ṡ`` in time with explicit RK4 [rad].

    Uses the prescribed trajectory of ``path`` (:func:`~magsail_mj.concepts.msac.cycle.cycle_state_scalar`)
    and a Python loop over ``cycles · steps_per_cycle`` fixed steps. Returns ``ψ`` at the end.
    Only for tests (fourth order in the step: 4000 steps per cycle give ~1e-12 relative).
    """
    if int(steps_per_cycle) != steps_per_cycle or steps_per_cycle < 4:
        raise ValueError(f"steps_per_cycle: must be an integer >= 4, got {steps_per_cycle!r}")
    h = path.period_s / steps_per_cycle
    m = model

    def rate(t: float) -> float:
        phi, phid, _, s, sd, _, _ = cycle_state_scalar(path, t)
        c = s + 0.5 * m.wing_length_m
        cos, sin = math.cos(phi), math.sin(phi)
        D = m.bus_izz_kgm2 + m.n_wings * (
            m.wing_icm_kgm2
            + m.root_inertia_kgm2
            + m.root_mass_kg * m.hinge_offset_m**2
            + m.wing_mass_kg * (m.hinge_offset_m**2 + c * c + 2 * m.hinge_offset_m * c * cos)
        )
        n_phi = m.n_wings * (
            m.wing_icm_kgm2 + m.root_inertia_kgm2 + m.wing_mass_kg * c * c + m.wing_mass_kg * m.hinge_offset_m * c * cos
        )
        n_s = m.n_wings * m.wing_mass_kg * m.hinge_offset_m * sin
        return -(n_phi * phid + n_s * sd) / D

    psi = 0.0
    for k in range(int(cycles) * int(steps_per_cycle)):
        t = k * h
        k1 = rate(t)
        k2 = rate(t + 0.5 * h)
        k4 = rate(t + h)
        psi += h * (k1 + 4.0 * k2 + k4) / 6.0  # ψ̇ depends on t only: RK4 = Simpson
    return psi
