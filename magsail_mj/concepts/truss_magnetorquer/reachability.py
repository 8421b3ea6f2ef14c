r"""Magnetic controllability of the truss slews along the orbit, and a reachability bound.

Robb et al. 2022a, Sec. 4.3: four 90° slews of the magnetorquer truss. This module asks whether a
slew can be done at all with the rods' dipoles in the field history of its run, for any
controller, before asking whether a control law does it.

**Achievable torques.** The rods of family ``f`` lie along the body unit vector ``u_f`` (the
undeformed strut direction) with ``n_f`` rods of dipole ``m_f`` each; every rod is switched to
``s_r ∈ {−1, 0, +1}``, so the total dipole lies in the zonotope (a box for two families)

.. math:: \mathcal D = \{\textstyle\sum_f \mu_f\,\mathbf u_f : |\mu_f| \le M_f = n_f m_f\}
    \qquad [\mathrm{A\,m^2}],

and the torque in the uniform field ``B`` (body axes) is ``τ = m × B``: the parallelogram
``{m × B : m ∈ 𝒟}`` in the plane normal to ``B`` (:func:`torque_vertices_Nm`). Its largest
component along a unit axis ``e`` (body axes) is its support function

.. math:: h(\mathbf e) = \max_{\mathbf m\in\mathcal D} \mathbf e\cdot(\mathbf m\times\mathbf B)
    = \max_{\mathbf m\in\mathcal D} \mathbf m\cdot(\mathbf B\times\mathbf e)
    = \textstyle\sum_f M_f\,|\mathbf u_f\cdot(\mathbf B\times\mathbf e)|
    \quad [\mathrm{N\,m}]

(:func:`max_torque_about_Nm`); it vanishes when ``e ∥ B``. For rods along body ``x`` and ``y``:
``h(x̂) = M_2 |B_z|``, ``h(ŷ) = M_1 |B_z|``, ``h(ẑ) = M_1 |B_y| + M_2 |B_x|`` — torque about an
in-plane axis needs field along the plate normal.

**Reachability bound (true for every controller and every attitude path).** Let ``θ`` be the
rotation angle from the initial to the target attitude (the angle of ``q_0^* ⊗ q_ref``). The
rotation angle is the bi-invariant distance on SO(3) whose line element is ``|ω| dt``, so every
attitude path satisfies ``θ ≤ ∫_0^T |ω| dt``. For a rigid body ``H = R J ω`` (inertial), hence
``|ω| ≤ |H| / J_min`` with ``J_min`` the smallest principal moment, and ``dH/dt = τ_mag + τ_gg``
(inertial, total external torque). With ``τ̄(t) ≥ |τ_mag + τ_gg|`` for every dipole and every
attitude, ``F(t) = ∫_0^t τ̄ du`` and endpoint momenta ``|H(0)| = H_0``, ``|H(T)| = H_T``:
``|H(t)| ≤ H_0 + F(t)`` and ``|H(t)| ≤ H_T + F(T) − F(t)``, so

.. math:: \theta \le \theta_\max(T) = \frac{1}{J_\min}\int_0^T
    \min\bigl(H_0 + F(t),\; H_T + F(T) - F(t)\bigr)\,dt
    \qquad [\mathrm{rad}]

(:func:`angle_bound_rad`). For rest to rest (``H_0 = H_T = 0``) the minimum switches at ``s``
with ``F(s) = F(T)/2``: the integral is ``∫_0^s F dt + ∫_s^T (F(T) − F) dt``, the angle of a
single-axis double integrator that accelerates with the full bound until half the available
impulse is spent and then decelerates; with a constant bound it is ``τ̄ T² / (4 J_min)``. The
attitude-free bound used here is

.. math:: \bar\tau(t) = |\mathbf B(t)|\,\max_{\mathbf m\in\mathcal D}|\mathbf m|
    + \frac{3\mu}{2 r(t)^3}\,(J_\max - J_\min),

the first term because ``|m × B| ≤ |m| |B|`` and ``|m|`` is largest at a vertex of ``𝒟``
(:func:`attitude_free_torque_bound_Nm`), the second the largest gravity-gradient torque
``3μ/r³ |r̂ × J r̂|`` over all orientations, since ``r̂ × J r̂ = r̂ × (J − c I) r̂`` with
``c = (J_max + J_min)/2`` and ``‖J − c I‖ = (J_max − J_min)/2``
(:func:`gravity_gradient_bound_Nm`); the gravity gradient is counted as an aid. A slew with
``θ > θ_max(T)`` is impossible for any controller with these rods in that time.

**Eigenaxis bound (true for every path that rotates about the fixed slew axis).** On the path
``q(φ) = q_0 ⊗ (cos φ/2, sin φ/2 e_b)``, ``φ ∈ [0, θ]``, the component of Euler's equation along
``e_b`` is ``J_e φ̈ = e·τ`` (``J_e = e_bᵀ J e_b``; ``e·(ω × J ω) = 0`` for ``ω ∥ e``), so the same
formula holds with ``J_e`` and ``τ̄_e(t) = max_φ h(e) + max_φ |e·τ_gg|`` over the path
(:func:`eigenaxis_torque_bound_Nm`: a grid over ``φ`` plus its Lipschitz bound, so it is still an
upper bound). It bounds only the eigenaxis paths: a controller may leave the axis.

Units SI; body axes are those of the undeformed lattice. Both bounds are for the rigid plate; the
lattice's surface standard deviation in the slew runs stays below 0.028 m on 75 m, which changes its
inertia by well under 1 %, against the factor of 27 by which the bound exceeds the demanded angle
(``scripts/truss_slew_reachability.py``).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from magsail_mj.environment.gravity import MU_EARTH
from magsail_mj.quaternion import quat_from_axis_angle, quat_mul, quat_to_axis_angle, quat_to_matrix

__all__ = [
    "DipoleZonotope",
    "SlewRotation",
    "rod_dipole_zonotope",
    "torque_vertices_Nm",
    "max_torque_about_Nm",
    "max_torque_norm_Nm",
    "attitude_free_torque_bound_Nm",
    "gravity_gradient_bound_Nm",
    "angle_bound_rad",
    "angle_bound_history_rad",
    "earliest_time_s",
    "slew_rotation",
    "eigenaxis_attitudes",
    "versine_fraction",
    "eigenaxis_torque_bound_Nm",
]


@dataclass(frozen=True)
class DipoleZonotope:
    """Achievable total dipoles ``{Σ_f μ_f u_f : |μ_f| ≤ M_f}`` (body axes).

    Attributes:
      directions: (F, 3) unit directions ``u_f`` of the families, body axes.
      max_dipole_Am2: (F,) largest family dipole ``M_f = n_f m_f`` [A m²].
    """

    directions: np.ndarray
    max_dipole_Am2: np.ndarray

    def __post_init__(self) -> None:
        u = np.asarray(self.directions, dtype=float)
        M = np.asarray(self.max_dipole_Am2, dtype=float)
        if u.ndim != 2 or u.shape[1] != 3 or u.shape[0] < 1:
            raise ValueError(f"directions: expected shape (F, 3), got {u.shape}")
        if not np.allclose(np.linalg.norm(u, axis=1), 1.0, atol=1e-9):
            raise ValueError("directions: every family direction must be a unit vector")
        if M.shape != (u.shape[0],) or not np.all(np.isfinite(M)) or np.any(M < 0):
            raise ValueError(f"max_dipole_Am2: expected {u.shape[0]} values >= 0 [A m²], got {M!r}")

    @property
    def generators_Am2(self) -> np.ndarray:
        """(F, 3) generators ``M_f u_f`` [A m²]."""
        return np.asarray(self.max_dipole_Am2, float)[:, None] * np.asarray(self.directions, float)

    def vertices_Am2(self) -> np.ndarray:
        """(2^F, 3) dipoles ``Σ_f ±M_f u_f`` (every vertex of the zonotope among them) [A m²]."""
        G = self.generators_Am2
        signs = np.array(list(itertools.product((-1.0, 1.0), repeat=G.shape[0])))
        return signs @ G

    @property
    def max_norm_Am2(self) -> float:
        """``max_{m ∈ 𝒟} |m|`` [A m²] (a convex function peaks at a vertex)."""
        return float(np.linalg.norm(self.vertices_Am2(), axis=1).max())


def rod_dipole_zonotope(
    rod_directions_body: np.ndarray, rod_dipole_Am2: np.ndarray, family: np.ndarray
) -> DipoleZonotope:
    """The zonotope of rods ``r`` with body directions ``rod_directions_body`` (n, 3), dipoles
    ``rod_dipole_Am2`` (n,) [A m²] and family index ``family`` (n,): ``M_f = Σ_{r ∈ f} m_r``.

    Every rod of a family must be parallel to the family's first rod (to 1e-9); the rods of a
    :class:`~magsail_mj.loads.magnetorquer_rods.MagnetorquerRodLoad` are, in the undeformed lattice.
    """
    d = np.asarray(rod_directions_body, dtype=float)
    m = np.asarray(rod_dipole_Am2, dtype=float)
    fam = np.asarray(family)
    if d.ndim != 2 or d.shape[1] != 3 or m.shape != (d.shape[0],) or fam.shape != (d.shape[0],):
        raise ValueError(
            f"rod_directions_body, rod_dipole_Am2, family: expected shapes (n, 3), (n,), (n,), "
            f"got {d.shape}, {m.shape}, {fam.shape}"
        )
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    dirs, Ms = [], []
    for f in np.unique(fam):
        sel = fam == f
        u = d[sel][0]
        if not np.allclose(np.abs(d[sel] @ u), 1.0, atol=1e-9):
            raise ValueError(f"rod_directions_body: the rods of family {f} are not parallel")
        dirs.append(u)
        Ms.append(float(m[sel].sum()))
    return DipoleZonotope(directions=np.array(dirs), max_dipole_Am2=np.array(Ms))


def torque_vertices_Nm(zono: DipoleZonotope, B_body_T: np.ndarray) -> np.ndarray:
    """(…, 2^F, 3) torques ``v × B`` of the zonotope's vertices ``v`` [N m], body axes: the
    achievable torques are their convex hull, a parallelogram normal to ``B`` (two families)."""
    B = np.asarray(B_body_T, dtype=float)
    V = zono.vertices_Am2()
    return np.cross(V, B[..., None, :])


def max_torque_about_Nm(zono: DipoleZonotope, B_body_T: np.ndarray, axis_body: np.ndarray) -> np.ndarray:
    """Support ``h(e) = Σ_f M_f |u_f · (B × ê)|`` [N m]: the largest achievable torque component
    along ``axis_body`` (normalised here); ``B_body_T`` (…, 3) [T] and the axis broadcast."""
    e = np.asarray(axis_body, dtype=float)
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    w = np.cross(np.asarray(B_body_T, dtype=float), e)
    return np.abs(w @ np.asarray(zono.directions, float).T) @ np.asarray(zono.max_dipole_Am2, float)


def max_torque_norm_Nm(zono: DipoleZonotope, B_body_T: np.ndarray) -> np.ndarray:
    """``max_{m ∈ 𝒟} |m × B|`` [N m] for the field ``B_body_T`` (…, 3) [T] in body axes
    (a convex function of ``m``, so its largest value is at a vertex)."""
    return np.linalg.norm(torque_vertices_Nm(zono, B_body_T), axis=-1).max(axis=-1)


def attitude_free_torque_bound_Nm(zono: DipoleZonotope, B_norm_T: np.ndarray) -> np.ndarray:
    """``max_{m ∈ 𝒟} |m| · |B|`` [N m]: no attitude gives a larger dipole torque."""
    return zono.max_norm_Am2 * np.asarray(B_norm_T, dtype=float)


def gravity_gradient_bound_Nm(r_norm_m: np.ndarray, inertia_kgm2: np.ndarray, *, mu: float = MU_EARTH) -> np.ndarray:
    """``3μ/(2 r³) (J_max − J_min)`` [N m]: the largest gravity-gradient torque over all
    orientations at distance ``r_norm_m`` [m] (module docstring)."""
    lam = np.linalg.eigvalsh(np.asarray(inertia_kgm2, dtype=float))
    r = np.asarray(r_norm_m, dtype=float)
    return 1.5 * mu / r**3 * (lam[-1] - lam[0])


def _check_series(t_s: np.ndarray, torque_bound_Nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t_s, dtype=float)
    tau = np.asarray(torque_bound_Nm, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
        raise ValueError("t_s: expected an increasing 1-D array of at least two times [s]")
    if tau.shape != t.shape or not np.all(np.isfinite(tau)) or np.any(tau < 0):
        raise ValueError(f"torque_bound_Nm: expected {t.size} finite values >= 0 [N m], like t_s")
    return t, tau


def _cumulative(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Trapezoidal ``∫_{t_0}^{t_k} y`` at every sample (0 at the first)."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))])


def angle_bound_rad(
    t_s: np.ndarray,
    torque_bound_Nm: np.ndarray,
    inertia_kgm2: float,
    *,
    h0_Nms: float = 0.0,
    hT_Nms: float = 0.0,
) -> float:
    r"""``θ_max`` of the module docstring over ``[t_s[0], t_s[-1]]`` [rad].

    ``(1/J) ∫ min(H_0 + F(t), H_T + F(T) − F(t)) dt`` with ``F`` the trapezoidal integral of the
    sampled ``torque_bound_Nm`` and the outer integral exact for ``F`` linear between samples
    (the minimum of two linear functions, split where they cross). The trapezoid's error is
    ``O(Δt²)`` relative for a smooth bound; the orbit's field changes over hundreds of seconds.
    ``inertia_kgm2`` is ``J_min`` (any path) or ``J_e`` (eigenaxis paths) [kg m²]; ``h0_Nms``,
    ``hT_Nms`` the endpoint momenta.
    """
    t, tau = _check_series(t_s, torque_bound_Nm)
    if not (np.isfinite(inertia_kgm2) and inertia_kgm2 > 0):
        raise ValueError(f"inertia_kgm2: must be > 0 [kg m²], got {inertia_kgm2!r}")
    if h0_Nms < 0 or hT_Nms < 0:
        raise ValueError(f"h0_Nms, hT_Nms: momenta magnitudes must be >= 0, got {h0_Nms!r}, {hT_Nms!r}")
    F = _cumulative(t, tau)
    a = h0_Nms + F
    b = hT_Nms + F[-1] - F
    return _integral_of_min(t, a, b) / float(inertia_kgm2)


def _integral_of_min(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """``∫ min(a, b) dt`` for ``a``, ``b`` linear between samples (split at a crossing)."""
    d0, d1 = (a - b)[:-1], (a - b)[1:]
    dt = np.diff(t)
    lo0, lo1 = np.minimum(a, b)[:-1], np.minimum(a, b)[1:]
    plain = 0.5 * (lo0 + lo1) * dt
    cross = d0 * d1 < 0
    if np.any(cross):
        s = d0[cross] / (d0[cross] - d1[cross])  # crossing at t_k + s dt
        a0, a1 = a[:-1][cross], a[1:][cross]
        ac = a0 + s * (a1 - a0)
        plain[cross] = 0.5 * (lo0[cross] + ac) * s * dt[cross] + 0.5 * (ac + lo1[cross]) * (1 - s) * dt[cross]
    return float(plain.sum())


def angle_bound_history_rad(t_s: np.ndarray, torque_bound_Nm: np.ndarray, inertia_kgm2: float) -> np.ndarray:
    """Rest-to-rest ``θ_max(T)`` for every sample time ``T = t_s[k]`` (start ``t_s[0]``) [rad];
    non-decreasing in ``T``. Each entry is :func:`angle_bound_rad` on ``t_s[:k+1]``."""
    t, tau = _check_series(t_s, torque_bound_Nm)
    out = np.zeros(t.size)
    for k in range(1, t.size):
        out[k] = angle_bound_rad(t[: k + 1], tau[: k + 1], inertia_kgm2)
    return out


def earliest_time_s(t_s: np.ndarray, theta_max_rad: np.ndarray, angle_rad: float) -> float:
    """First sample time with ``θ_max(T) ≥ angle_rad`` (``inf`` if none) [s]: no controller
    finishes the rest-to-rest slew earlier."""
    ok = np.nonzero(np.asarray(theta_max_rad) >= angle_rad)[0]
    return float(np.asarray(t_s)[ok[0]]) if ok.size else math.inf


@dataclass(frozen=True)
class SlewRotation:
    """The rotation ``q_0 → q_ref`` (body → inertial quaternions, scalar first).

    Attributes:
      angle_rad: rotation angle ``θ ∈ [0, π]`` of ``q_0^* ⊗ q_ref``.
      axis_body: unit axis ``e_b`` in body axes (``q_ref = q_0 ⊗ (cos θ/2, sin θ/2 e_b)``).
      axis_inertial: the same axis in inertial axes, ``R(q_0) e_b``.
    """

    angle_rad: float
    axis_body: np.ndarray
    axis_inertial: np.ndarray


def slew_rotation(q0_wxyz: np.ndarray, q_ref_wxyz: np.ndarray) -> SlewRotation:
    """Angle and axis of the shortest rotation from ``q0_wxyz`` to ``q_ref_wxyz``."""
    q0 = np.asarray(q0_wxyz, dtype=float) / np.linalg.norm(q0_wxyz)
    qr = np.asarray(q_ref_wxyz, dtype=float) / np.linalg.norm(q_ref_wxyz)
    q_rel = quat_mul(np.array([q0[0], -q0[1], -q0[2], -q0[3]]), qr)
    axis, angle = quat_to_axis_angle(q_rel)
    return SlewRotation(angle_rad=float(angle), axis_body=axis, axis_inertial=quat_to_matrix(q0) @ axis)


def versine_fraction(t_s: np.ndarray, duration_s: float) -> np.ndarray:
    """Rest-to-rest fraction ``f = τ − sin(2πτ)/(2π)``, ``τ = clip(t/T, 0, 1)``: ``f̈ ∝ sin(2πτ)``,
    ``f(0) = 0``, ``f(T) = 1``, zero rate at both ends; peak ``f̈ = 2π/T²``."""
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s: must be > 0 [s], got {duration_s!r}")
    tau = np.clip(np.asarray(t_s, dtype=float) / duration_s, 0.0, 1.0)
    return tau - np.sin(2 * np.pi * tau) / (2 * np.pi)


def eigenaxis_attitudes(rotation: SlewRotation, q0_wxyz: np.ndarray, phi_rad: np.ndarray) -> np.ndarray:
    """(…, 4) attitudes ``q_0 ⊗ (cos φ/2, sin φ/2 e_b)`` at the angles ``phi_rad`` along the slew."""
    q0 = np.asarray(q0_wxyz, dtype=float) / np.linalg.norm(q0_wxyz)
    phi = np.asarray(phi_rad, dtype=float)
    q_rel = quat_from_axis_angle(np.broadcast_to(rotation.axis_body, phi.shape + (3,)), phi)
    return quat_mul(np.broadcast_to(q0, q_rel.shape), q_rel)


def _gravity_gradient_rows(r_m: np.ndarray, inertia_kgm2: np.ndarray, *, mu: float) -> np.ndarray:
    """``3μ/|r|³ r̂ × J r̂`` for every row of ``r_m`` (n, 3) [N m], the frame of ``r_m`` and ``J``."""
    rn = np.linalg.norm(r_m, axis=1, keepdims=True)
    u = r_m / rn
    return 3.0 * mu / rn**3 * np.cross(u, u @ np.asarray(inertia_kgm2, dtype=float).T)


def eigenaxis_torque_bound_Nm(
    zono: DipoleZonotope,
    rotation: SlewRotation,
    q0_wxyz: np.ndarray,
    B_eci_T: np.ndarray,
    r_eci_m: np.ndarray,
    inertia_kgm2: np.ndarray,
    *,
    n_phi: int = 181,
    mu: float = MU_EARTH,
) -> np.ndarray:
    r"""``τ̄_e(t) ≥ max_{φ∈[0,θ]} h(e) + max_φ |e·τ_gg|`` along the eigenaxis path [N m], (K,).

    ``B_eci_T``, ``r_eci_m`` (K, 3): the field [T] and position [m] history. The maxima are taken
    on ``n_phi`` angles ``Δφ = θ/(n_phi − 1)`` apart, plus their Lipschitz bounds over half a
    step: ``|dh/dφ| ≤ |B| Σ_f M_f`` (rotating ``B`` by ``dφ`` moves ``B × e`` by at most
    ``|B| dφ``) and ``|d(e·τ_gg)/dφ| ≤ 3μ/r³ (J_max − J_min)``, so the result is an upper bound.
    """
    if n_phi < 2:
        raise ValueError(f"n_phi: need at least 2 angles, got {n_phi!r}")
    B = np.asarray(B_eci_T, dtype=float)
    r = np.asarray(r_eci_m, dtype=float)
    J = np.asarray(inertia_kgm2, dtype=float)
    e = rotation.axis_body
    phi = np.linspace(0.0, rotation.angle_rad, n_phi)
    Rs = np.array([quat_to_matrix(q) for q in eigenaxis_attitudes(rotation, q0_wxyz, phi)])  # (P, 3, 3)
    B_b = np.einsum("pji,kj->kpi", Rs, B)  # Rᵀ B for every time and angle
    r_b = np.einsum("pji,kj->kpi", Rs, r)
    h = max_torque_about_Nm(zono, B_b, e).max(axis=1)
    gg = np.abs(_gravity_gradient_rows(r_b.reshape(-1, 3), J, mu=mu) @ e).reshape(B.shape[0], n_phi).max(axis=1)
    half = 0.5 * (phi[1] - phi[0])
    lam = np.linalg.eigvalsh(J)
    rn = np.linalg.norm(r, axis=1)
    lip_mag = np.linalg.norm(B, axis=1) * float(np.sum(zono.max_dipole_Am2))
    lip_gg = 3 * mu / rn**3 * (lam[-1] - lam[0])
    slack = half * (lip_mag + lip_gg)
    return h + gg + slack
