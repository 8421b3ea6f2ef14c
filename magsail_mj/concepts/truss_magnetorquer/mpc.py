r"""Receding-horizon (model-predictive) control of the truss attitude with the rod dipoles.

The rods can only make torques ``m × B`` normal to the field, and the field along the orbit is
known in advance (IGRF along the reference orbit). This controller plans the rods' total dipole
over a horizon against that field history, with the gravity gradient in the model, and applies
the first piece of the plan (receding horizon).

**Prediction model** (rigid plate, orbit-following frame with ECI axes; body axes of the
undeformed lattice):

.. math::

    J\dot{\boldsymbol\omega} = -\boldsymbol\omega\times J\boldsymbol\omega
        + \mathbf m\times\mathbf B_b + \frac{3\mu}{|\mathbf r|^5}\,\mathbf r_b\times J\mathbf r_b,
    \qquad \dot q = \tfrac12\,q\otimes(0,\boldsymbol\omega),

``B_b = Rᵀ B(t)``, ``r_b = Rᵀ r(t)`` (field [T] and position [m] from the forecast),
``m = S u = (u_1, u_2, 0)`` [A m²] the total dipole of the two rod families along body ``x``
and ``y``, bounded by ``|u_f| ≤ M_f = n_f m_f`` (all rods of a family on).

**Linearisation** about a nominal trajectory ``(q̄_k, ω̄_k, ū_k)`` (RK4 rollout of the model with
the previous plan shifted by one step), with the body-frame perturbation
``q = q̄ ⊗ (1, δθ/2)`` and ``ω = ω̄ + δω``:

.. math::

    \dot{\delta\theta} = -[\bar\omega]_\times\delta\theta + \delta\omega,\qquad
    J\dot{\delta\omega} = \bigl([\bar{\mathbf m}]_\times[\bar{\mathbf B}_b]_\times
        + k([\bar{\mathbf r}_b]_\times J - [J\bar{\mathbf r}_b]_\times)[\bar{\mathbf r}_b]_\times\bigr)\delta\theta
        + ([J\bar\omega]_\times - [\bar\omega]_\times J)\,\delta\omega
        - [\bar{\mathbf B}_b]_\times S\,\delta\mathbf u,

``k = 3μ/|r|⁵`` (``B_b`` and ``r_b`` move by ``B_b × δθ`` and ``r_b × δθ``). The pair
``(A_c, B_c)`` of each step is evaluated at the step's start and discretised over the step ``h``
with the dipole held (zero-order hold), ``exp([[A_c, B_c], [0, 0]] h) = [[Φ_k, Γ_k], [0, I]]``
(:func:`linearise`; tested against finite differences of the rollout).

**Plan** (one bounded linear least-squares problem per replan, ``scipy.optimize.lsq_linear``):

.. math::

    \min_{\mathbf u}\ \sum_{k=1}^{N} w_k\Bigl(\bigl|\mathbf e_k + E_k\,\delta\boldsymbol\theta_k\bigr|^2
        + \bigl|T_\omega(\bar{\boldsymbol\omega}_k + \delta\boldsymbol\omega_k)\bigr|^2\Bigr)
        + \rho\sum_k |\mathbf u_k / M|^2 + \sigma\sum_k |(\mathbf u_k - \bar{\mathbf u}_k)/M|^2,
    \qquad |u_{k,f}| \le M_f,

with ``(δθ_k, δω_k) = Σ_{j<k} G_{kj} δu_j`` the condensed linear prediction, ``e = 2 sgn(q_{e0})
q_{e,vec}`` the attitude error of ``q_e = q_ref* ⊗ q`` (rad for small angles),
``E = sgn(q_{e0}) (q_{e0} I + [q_{e,vec}]_×)`` its Jacobian, ``T_ω`` [s] the weight of the rate,
``w_k = 1`` except ``w_N = terminal_weight``, ``ρ`` the effort weight and ``σ`` a step penalty
that keeps the plan near the nominal where the linearisation holds. ``iterations`` rollouts and
solves per replan (sequential quadratic programming, warm-started from the previous plan).

The controller replans every ``replan_s`` and holds its planned dipole in between. Its
reference torque for the rod allocation is ``T_ref = m × B_b`` with the held dipole, which the
exact allocation (``control.allocation = "exact"``) turns back into ``N_f = u_f / m_f`` rods.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Unpack

import numpy as np
from scipy.linalg import expm
from scipy.optimize import lsq_linear
from threadpoolctl import threadpool_limits

from magsail_mj.control.rod_attitude import RodAttitudeController, RodControllerOptions
from magsail_mj.quaternion import quat_from_matrix, quat_mul

__all__ = [
    "FieldForecast",
    "RigidPlant",
    "MpcWeights",
    "skew",
    "error_vector",
    "rollout",
    "linearise",
    "plan_dipoles",
    "MagneticMpcController",
]

FieldForecast = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""``t (K,) [s] → (B_eci (K, 3) [T], r_eci (K, 3) [m])``: the known field and position history."""


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]_×`` for ``v`` (…, 3): the (…, 3, 3) matrix with ``[v]_× a = v × a``."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], axis=-1),
            np.stack([v[..., 2], z, -v[..., 0]], axis=-1),
            np.stack([-v[..., 1], v[..., 0], z], axis=-1),
        ],
        axis=-2,
    )


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` over the last axis (broadcast), without ``np.cross``'s per-call overhead."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _rotate_to_body(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q)ᵀ v`` for unit quaternions ``q`` (…, 4) and vectors ``v`` (…, 3)."""
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * _cross(u, v)
    return v - w * t + _cross(u, t)


@dataclass(frozen=True)
class RigidPlant:
    """The rigid prediction model.

    Attributes:
      inertia_kgm2: (3, 3) inertia about the centre of mass, body axes [kg m²].
      max_dipole_Am2: (2,) ``M_f = n_f m_f`` of the families along body x and y [A m²].
      mu_m3_s2: gravitational parameter [m³/s²].
      forecast: the field and position history (:data:`FieldForecast`).
      gravity_gradient: include the gravity-gradient torque.
    """

    inertia_kgm2: np.ndarray
    max_dipole_Am2: np.ndarray
    mu_m3_s2: float
    forecast: FieldForecast
    gravity_gradient: bool = True

    def __post_init__(self) -> None:
        J = np.asarray(self.inertia_kgm2, dtype=float)
        if J.shape != (3, 3) or not np.allclose(J, J.T) or not np.all(np.linalg.eigvalsh(J) > 0):
            raise ValueError(f"inertia_kgm2: expected a symmetric positive definite (3, 3) tensor, got {J!r}")
        M = np.asarray(self.max_dipole_Am2, dtype=float)
        if M.shape != (2,) or not np.all(np.isfinite(M)) or np.any(M <= 0):
            raise ValueError(f"max_dipole_Am2: expected 2 values > 0 [A m²], got {self.max_dipole_Am2!r}")
        if not (math.isfinite(self.mu_m3_s2) and self.mu_m3_s2 > 0):
            raise ValueError(f"mu_m3_s2: must be > 0, got {self.mu_m3_s2!r}")
        object.__setattr__(self, "inertia_kgm2", J)
        object.__setattr__(self, "max_dipole_Am2", M)
        object.__setattr__(self, "_J_inv", np.linalg.inv(J))

    def rhs(
        self, q: np.ndarray, w: np.ndarray, m_body: np.ndarray, B_eci: np.ndarray, r_eci: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(q̇, ω̇)`` of the module equations; every argument (…, 3 or 4), broadcast."""
        J = self.inertia_kgm2
        B_b = _rotate_to_body(q, B_eci)
        T = _cross(m_body, B_b) - _cross(w, w @ J.T)
        if self.gravity_gradient:
            r_b = _rotate_to_body(q, r_eci)
            rn = np.linalg.norm(r_b, axis=-1, keepdims=True)
            T = T + 3.0 * self.mu_m3_s2 / rn**5 * _cross(r_b, r_b @ J.T)
        w4 = np.concatenate([np.zeros(w.shape[:-1] + (1,)), w], axis=-1)
        return 0.5 * quat_mul(q, w4), T @ self._J_inv.T  # type: ignore[attr-defined]


@dataclass(frozen=True)
class MpcWeights:
    """Weights and grid of the plan (module docstring).

    Attributes:
      horizon_s: prediction horizon ``N h`` [s]; step_s: step ``h`` with the dipole held [s];
      substeps: RK4 steps per ``h`` in the rollout; rate_weight_s: ``T_ω`` [s];
      terminal_weight: ``w_N``; effort_weight: ``ρ``; step_weight: ``σ``; iterations: SQP
      iterations per replan.
    """

    horizon_s: float = 3600.0
    step_s: float = 60.0
    substeps: int = 3
    rate_weight_s: float = 1000.0
    terminal_weight: float = 10.0
    effort_weight: float = 1e-4
    step_weight: float = 1e-3
    iterations: int = 1

    def __post_init__(self) -> None:
        for name in ("horizon_s", "step_s", "rate_weight_s", "terminal_weight"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be > 0, got {v!r}")
        for name in ("effort_weight", "step_weight"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name}: must be >= 0, got {v!r}")
        if self.horizon_s < self.step_s:
            raise ValueError(f"horizon_s: must be >= step_s = {self.step_s} s, got {self.horizon_s!r}")
        if int(self.substeps) != self.substeps or self.substeps < 1:
            raise ValueError(f"substeps: must be an integer >= 1, got {self.substeps!r}")
        if int(self.iterations) != self.iterations or self.iterations < 1:
            raise ValueError(f"iterations: must be an integer >= 1, got {self.iterations!r}")

    @property
    def n_steps(self) -> int:
        """``N = round(horizon_s / step_s)``."""
        return int(round(self.horizon_s / self.step_s))


def error_vector(q_ref: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(e, E)``: ``e = 2 sgn(q_e0) q_e,vec`` of ``q_e = q_ref* ⊗ q`` (…, 3) and its Jacobian
    ``E = ∂e/∂δθ = sgn(q_e0)(q_e0 I + [q_e,vec]_×)`` (…, 3, 3) for ``q ⊗ (1, δθ/2)``."""
    qr = np.asarray(q_ref, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])
    qe = quat_mul(np.broadcast_to(qr, np.shape(q)), q)
    s = np.where(qe[..., :1] < 0, -1.0, 1.0)
    qe = s * qe
    E = qe[..., 0, None, None] * np.eye(3) + skew(qe[..., 1:])
    return 2.0 * qe[..., 1:], E


def rollout(
    plant: RigidPlant, q0: np.ndarray, w0: np.ndarray, t0_s: float, U_Am2: np.ndarray, weights: MpcWeights
) -> tuple[np.ndarray, np.ndarray]:
    """States ``(q (N+1, 4), ω (N+1, 3))`` at ``t0 + k h`` of RK4 (``substeps`` per step) with the
    dipoles ``U_Am2`` (N, 2) held over each step; ``q0``/``ω0`` may carry a leading batch axis
    (then ``U_Am2`` (P, N, 2) and the outputs (P, N+1, …))."""
    h = weights.step_s
    ns = int(weights.substeps)
    dt = h / ns
    N = U_Am2.shape[-2]
    t = t0_s + dt * np.arange(N * ns * 2 + 1) / 2.0
    B_all, r_all = plant.forecast(t)
    q, w = np.asarray(q0, dtype=float).copy(), np.asarray(w0, dtype=float).copy()
    qs, ws = [q], [w]
    m = np.zeros(U_Am2.shape[:-1] + (3,))
    m[..., :2] = U_Am2
    for k in range(N):
        mk = m[..., k, :]
        for s in range(ns):
            i = 2 * (k * ns + s)
            k1 = plant.rhs(q, w, mk, B_all[i], r_all[i])
            k2 = plant.rhs(q + 0.5 * dt * k1[0], w + 0.5 * dt * k1[1], mk, B_all[i + 1], r_all[i + 1])
            k3 = plant.rhs(q + 0.5 * dt * k2[0], w + 0.5 * dt * k2[1], mk, B_all[i + 1], r_all[i + 1])
            k4 = plant.rhs(q + dt * k3[0], w + dt * k3[1], mk, B_all[i + 2], r_all[i + 2])
            q = q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            q = q / np.linalg.norm(q, axis=-1, keepdims=True)
            w = w + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        qs.append(q)
        ws.append(w)
    return np.stack(qs, axis=-2), np.stack(ws, axis=-2)


def linearise(
    plant: RigidPlant, q: np.ndarray, w: np.ndarray, U_Am2: np.ndarray, t_s: np.ndarray, step_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Discrete ``(Φ (N, 6, 6), Γ (N, 6, 2))`` of the perturbation ``(δθ, δω)`` over steps of
    ``step_s`` from the states ``q`` (N, 4), ``ω`` (N, 3) at times ``t_s`` (N,) with the
    dipoles ``U_Am2`` (N, 2) held (module docstring; zero-order hold, matrix exponential)."""
    J = plant.inertia_kgm2
    Ji = np.linalg.inv(J)
    B_eci, r_eci = plant.forecast(np.asarray(t_s, dtype=float))
    B_b = _rotate_to_body(q, B_eci)
    m = np.concatenate([U_Am2, np.zeros(U_Am2.shape[:-1] + (1,))], axis=-1)
    K = skew(m) @ skew(B_b)
    if plant.gravity_gradient:
        r_b = _rotate_to_body(q, r_eci)
        rn = np.linalg.norm(r_b, axis=-1)
        k = 3.0 * plant.mu_m3_s2 / rn**5
        K = K + k[:, None, None] * (skew(r_b) @ J - skew(r_b @ J.T)) @ skew(r_b)
    N = q.shape[0]
    Z = np.zeros((N, 8, 8))
    Z[:, :3, :3] = -skew(w)
    Z[:, :3, 3:6] = np.eye(3)
    Z[:, 3:6, :3] = Ji @ K
    Z[:, 3:6, 3:6] = Ji @ (skew(w @ J.T) - skew(w) @ J)
    Z[:, 3:6, 6:8] = -(Ji @ skew(B_b))[:, :, :2]
    F = expm(Z * step_s)
    return F[:, :6, :6], F[:, :6, 6:8]


@threadpool_limits.wrap(limits=1)
def plan_dipoles(
    plant: RigidPlant,
    *,
    q_ref: np.ndarray,
    q0: np.ndarray,
    w0: np.ndarray,
    t0_s: float,
    U_guess_Am2: np.ndarray,
    weights: MpcWeights,
) -> tuple[np.ndarray, dict[str, float]]:
    """The planned dipoles ``U`` (N, 2) [A m²] from the state ``(q0, ω0)`` at ``t0_s`` (module
    docstring), and figures of the plan (predicted final error [rad], cost). BLAS runs on one
    thread here: the matrices are small, and threads cost more than they give on a shared machine."""
    W = weights
    N, h = W.n_steps, W.step_s
    M = plant.max_dipole_Am2
    U = np.clip(np.asarray(U_guess_Am2, dtype=float), -M, M)
    if U.shape != (N, 2):
        raise ValueError(f"U_guess_Am2: expected shape ({N}, 2), got {U.shape}")
    wk = np.ones(N)
    wk[-1] = W.terminal_weight
    sq = np.sqrt(wk)
    info: dict[str, float] = {}
    for _ in range(int(W.iterations)):
        qn, wn = rollout(plant, q0, w0, t0_s, U, W)
        Phi, Gam = linearise(plant, qn[:-1], wn[:-1], U, t0_s + h * np.arange(N), h)
        Gam = Gam * M  # variables scaled: v = u / M
        G = np.zeros((N, 6, 2 * N))
        acc = np.zeros((6, 2 * N))
        for k in range(N):
            acc = Phi[k] @ acc
            acc[:, 2 * k : 2 * k + 2] += Gam[k]
            G[k] = acc
        e, E = error_vector(q_ref, qn[1:])
        A_e = E @ G[:, :3, :]  # (N, 3, 2N)
        A_w = W.rate_weight_s * G[:, 3:, :]
        reg = W.effort_weight + W.step_weight
        rows = [
            (sq[:, None, None] * A_e).reshape(3 * N, 2 * N),
            (sq[:, None, None] * A_w).reshape(3 * N, 2 * N),
            math.sqrt(reg) * np.eye(2 * N),
        ]
        v_bar = (U / M).reshape(-1)
        rhs = [
            -(sq[:, None] * e).reshape(-1),
            -(sq[:, None] * W.rate_weight_s * wn[1:]).reshape(-1),
            # ρ|v|² + σ|v − v̄|² = (ρ + σ)|v − σ v̄/(ρ + σ)|² + const; variables δv = v − v̄
            -math.sqrt(reg) * v_bar * W.effort_weight / reg if reg > 0 else np.zeros(2 * N),
        ]
        A = np.concatenate(rows)
        b = np.concatenate(rhs)
        res = lsq_linear(A, b, bounds=(-1.0 - v_bar, 1.0 - v_bar), method="bvls")
        U = ((v_bar + res.x).reshape(N, 2)) * M
        info = {"cost": float(res.cost), "pred_error_rad": float(np.linalg.norm(e[-1] + A_e[-1] @ res.x))}
    return np.clip(U, -M, M), info


class MagneticMpcController(RodAttitudeController):
    """Receding-horizon rod control (``control.kind = "mpc"``, module docstring).

    Args:
      q_ref_wxyz: target attitude (body → inertial, scalar first).
      plant: the prediction model (:class:`RigidPlant`).
      weights: horizon and weights (:class:`MpcWeights`).
      replan_s: time between replans [s] (the planned dipole is held in between).
      Other arguments: see :class:`~magsail_mj.control.rod_attitude.RodAttitudeController`.

    ``RodCommand.extra`` holds ``dipole_Am2`` (3,) (the held total dipole, body axes) and
    ``pred_error_rad`` (the plan's predicted error at the horizon).
    """

    law = "mpc"

    def __init__(
        self,
        *,
        q_ref_wxyz: np.ndarray,
        plant: RigidPlant,
        weights: MpcWeights,
        replan_s: float,
        **base: Unpack[RodControllerOptions],
    ) -> None:
        super().__init__(**base)
        q = np.asarray(q_ref_wxyz, dtype=float)
        if q.shape != (4,) or not np.all(np.isfinite(q)) or not np.linalg.norm(q) > 0:
            raise ValueError(f"q_ref_wxyz: expected a non-zero quaternion [w, x, y, z], got {q_ref_wxyz!r}")
        if not (math.isfinite(replan_s) and replan_s > 0):
            raise ValueError(f"replan_s: must be > 0 s, got {replan_s!r}")
        self.q_ref = q / np.linalg.norm(q)
        self.plant = plant
        self.weights = weights
        self.replan_s = float(replan_s)
        self._U = np.zeros((weights.n_steps, 2))
        self._t_plan = -math.inf
        self._m = np.zeros(3)
        self._pred = math.nan

    def reference_torque(
        self, *, t: float, R: np.ndarray, omega_body: np.ndarray, B_body: np.ndarray, com_world: np.ndarray, env: Any
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """``T_ref = m × B_b`` with the held planned dipole ``m``; replans every ``replan_s``."""
        if t >= self._t_plan + self.replan_s - 1e-9:
            q = _quat_from_R(R)
            steps = int(round((t - self._t_plan) / self.weights.step_s)) if math.isfinite(self._t_plan) else 0
            guess = np.concatenate([self._U[steps:], np.repeat(self._U[-1:], min(steps, len(self._U)), axis=0)])[
                : len(self._U)
            ]
            self._U, info = plan_dipoles(
                self.plant, q_ref=self.q_ref, q0=q, w0=omega_body, t0_s=t, U_guess_Am2=guess, weights=self.weights
            )
            self._t_plan = t
            self._m = np.array([self._U[0, 0], self._U[0, 1], 0.0])
            self._pred = info["pred_error_rad"]
        return np.cross(self._m, B_body), {"dipole_Am2": self._m.copy(), "pred_error_rad": self._pred}


def _quat_from_R(R: np.ndarray) -> np.ndarray:
    q = quat_from_matrix(R)
    return q / np.linalg.norm(q)
