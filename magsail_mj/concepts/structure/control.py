r"""Attitude control of a flexible structure through magnetorquer rods and current loops: B-dot and
quaternion PD on the best-fit rigid attitude, and the dipole's allocation over the actuators.

One control sample (every ``period_s``; the runner holds the command in between):

1. **attitude**: the least-squares rigid fit (Kabsch,
   :class:`~magsail_mj.estimation.attitude.BestFitRotation`) of the nodes' world positions to their
   reference positions gives ``R`` (body → world; body = the structure frame);
2. **rate**: the backward difference of consecutive samples,
   ``ω = vee(log(R_prevᵀ R)) / (t − t_prev)`` (:func:`~magsail_mj.control.rod_attitude.step_rate`);
   the known initial rate at the first sample;
3. **field** in body axes ``B_b = Rᵀ B`` (the field at the reference point);
4. **reference torque** ``T_ref`` (body axes): B-dot ``k (ω × B_b) × B_b``
   (:func:`~magsail_mj.control.bdot_flexible.bdot_torque`), or quaternion PD
   ``−P_q q_e,vec − P_ω ω`` with ``q_e = q_ref* ⊗ q`` plus, in orbit, the gravity-gradient
   compensation ``−3μ/r⁵ r_b × (I r_b)``, ``r_b = Rᵀ (r_ref + x_c)``
   (:mod:`magsail_mj.control.quaternion_feedback`);
5. **allocation** (:class:`DipoleAllocation`, :func:`least_norm_activations`): the dipole
   ``m = B_b × T_ref / |B_b|²`` — the least dipole whose torque ``m × B_b`` is ``T_ref``'s
   component across the field (the component along ``B_b`` cannot be made) — shared over the
   actuators by the least-norm activations ``u = D⁺ m``; when some ``|u_k|`` would exceed 1 all are
   scaled by the same factor (the dipole keeps its direction; the sample counts as saturated).
   ``D``'s columns are the rods' largest dipoles ``m_max,r r̂_r`` along their reference axes
   (``u_r`` the rod's activation) and the current loops' largest dipoles ``I_max,L a_L`` with their
   vector areas ``a_L = Rᵀ ½ Σ x_a × x_b`` at the sampled node positions (``u_L = I_L / I_max,L``;
   for loops of one limit, the least-norm currents); ``D⁺`` is formed once for rods alone, at every
   sample when there are loops (their vector areas change with the shape), then dropping the
   directions ``D`` makes at under :data:`LOOP_PINV_RCOND` of its strongest.

The command (:class:`DipoleCommand`) is plain data: the run's checkpoints hold it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from magsail_mj.checkpoint import restorable
from magsail_mj.concepts.structure.loads import LoopLorentzLoad
from magsail_mj.concepts.structure.model import NodeFrames
from magsail_mj.control.bdot_flexible import bdot_torque
from magsail_mj.control.quaternion_feedback import gg_compensation_torque, quaternion_feedback_torque
from magsail_mj.control.rod_attitude import step_rate
from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.quaternion import error_quaternion, quat_from_matrix
from magsail_mj.vec3 import cross3

__all__ = [
    "DipoleAllocation",
    "DipoleCommand",
    "StructureRodController",
    "PINV_RCOND",
    "LOOP_PINV_RCOND",
    "least_norm_activations",
]

#: Singular values of the rods' dipole matrix below this fraction of the largest are dropped from
#: the pseudo-inverse: rods in one plane (a sail's booms) make no dipole across it.
PINV_RCOND = 1e-9

#: With current loops, singular values of ``D`` below this fraction of the largest are dropped from
#: the pseudo-inverse. The loops' vector areas come from the deformed shape: loops in one plane (a
#: reflector's two rims) make, besides their dipole along the normal, dipoles across it of a few
#: parts in 1e5 of it, opened by the deformation. The exact least-norm currents for a dipole with
#: a component there are huge and opposite (measured: the two rims of the 100 m reflector at
#: 1e-5), saturate every sample and cancel the useful dipole; a direction the actuators make at
#: under 1e-3 of their strongest is not used.
LOOP_PINV_RCOND = 1e-3


@restorable
@dataclass
class DipoleCommand:
    """The zero-order-held output of one control sample.

    Attributes:
      t: sample time [s].
      activation: (R,) rod activations ``u_r ∈ [−1, 1]`` (read by the rod load).
      currents_A: (L,) loop currents ``I_L ∈ [−I_max,L, I_max,L]`` [A] (read by the loop load;
        empty without loops).
      torque_ref_body: (3,) the law's reference torque [N m], body axes.
      torque_alloc_body: (3,) the torque the allocated dipole makes in the sampled field,
        ``(D u) × B_b`` [N m], body axes.
      dipole_body: (3,) the allocated dipole ``D u`` [A m²], body axes (undeformed rod axes, the
        loops' sampled vector areas).
      saturated: the activations were scaled down to stay within ±1.
      R: (3, 3) best-fit rotation, body → world.
      omega_body: (3,) estimated body rate [rad/s].
      B_body: (3,) field [T], body axes.
      com_world: (3,) centre of mass of the mass points [m], world.
      q_err: (4,) the PD law's error quaternion (identity for B-dot).
      counts: (2,) control samples so far and saturated samples among them.
    """

    t: float
    activation: np.ndarray
    torque_ref_body: np.ndarray
    torque_alloc_body: np.ndarray
    dipole_body: np.ndarray
    saturated: bool
    R: np.ndarray
    omega_body: np.ndarray
    B_body: np.ndarray
    com_world: np.ndarray
    q_err: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    counts: np.ndarray = field(default_factory=lambda: np.zeros(2, dtype=np.int64))
    currents_A: np.ndarray = field(default_factory=lambda: np.zeros(0))


def least_norm_activations(D_pinv: np.ndarray, torque_body: np.ndarray, B_body: np.ndarray) -> tuple[np.ndarray, bool]:
    """``(u, saturated)``: the least-norm activations ``u = D⁺ m`` of the dipole
    ``m = B × T / |B|²`` for the torque ``torque_body`` [N m] in the field ``B_body`` [T], all
    divided by ``max |u_k|`` when that passes 1 (module docstring, step 5).

    Scale-safe: the direction of ``m`` is formed from the normalised torque, its size
    ``|B × T| / |B|²`` separately, so no product overflows before the saturation test."""
    T = np.asarray(torque_body, dtype=float)
    B = np.asarray(B_body, dtype=float)
    n = D_pinv.shape[0]
    scale = float(np.max(np.abs(T)))
    B_norm = float(np.sqrt(B @ B))
    if n == 0 or not (scale > 0 and B_norm > 0):
        return np.zeros(n), False
    c = cross3(B, T / scale)
    c_norm = float(np.sqrt(c @ c))
    if not c_norm > 0:
        return np.zeros(n), False
    size = scale * (c_norm / B_norm) / B_norm  # |m| [A m²]
    v = D_pinv @ (c / c_norm)
    v_max = float(np.max(np.abs(v)))
    if not v_max > 0:
        return np.zeros(n), False
    if size * v_max > 1.0:
        return v / v_max, True
    return size * v, False


class DipoleAllocation:
    """Least-norm rod activations for a wanted torque (module docstring, step 5).

    Args:
      axes_body: (R, 3) unit axes of the rods in the body (reference) frame.
      dipole_max_Am2: (R,) each rod's largest dipole [A m²].

    ``D = [m_max,r r̂_r]`` (3 × R); its pseudo-inverse ``D⁺`` (:data:`PINV_RCOND`) is built once.
    """

    def __init__(self, axes_body: np.ndarray, dipole_max_Am2: np.ndarray) -> None:
        axes = np.asarray(axes_body, dtype=float).reshape(-1, 3)
        m = np.asarray(dipole_max_Am2, dtype=float)
        if m.shape != (axes.shape[0],) or not np.all(np.isfinite(m) & (m >= 0)):
            raise ValueError(f"dipole_max_Am2: {axes.shape[0]} dipoles >= 0 [A m²] needed, got shape {m.shape}")
        self.D = (axes * m[:, None]).T
        self.D_pinv = np.linalg.pinv(self.D, rcond=PINV_RCOND)

    def __call__(self, torque_body: np.ndarray, B_body: np.ndarray) -> tuple[np.ndarray, bool]:
        """``(u, saturated)`` for the torque ``torque_body`` [N m] in the field ``B_body`` [T]
        (:func:`least_norm_activations`)."""
        return least_norm_activations(self.D_pinv, torque_body, B_body)


class StructureRodController:
    """B-dot (``law = "bdot"``) or quaternion PD (``"quat_pd"``) through the rods and the current
    loops (module docstring).

    Args:
      nodes: the nodes' frames; reference_m: (n, 3) their reference positions [m].
      masses: the mass points (their frames and masses: the centre of mass).
      allocation: the rods' :class:`DipoleAllocation` (no rods: one of zero rods).
      loops: the current loops' load (:class:`~magsail_mj.concepts.structure.loads.LoopLorentzLoad`:
        their vector areas at a state and their current limits), or ``None``.
      law: ``"bdot"`` or ``"quat_pd"``.
      period_s: control period [s].
      omega0_body: (3,) the rate used at the first sample [rad/s].
      k_bdot_Nms_T2: B-dot gain [N m s/T²].
      q_ref_wxyz, Pq_Nm, Pw_Nms: the PD target (body → world) and diagonal gains [N m], [N m s].
      inertia_kgm2: (3, 3) inertia about the centre of mass, body axes (the compensation) [kg m²].
      mu_m3_s2: gravitational parameter of the compensation [m³/s²], or ``None`` (none: no orbit,
        or ``gg_comp`` off).
    """

    def __init__(
        self,
        *,
        nodes: NodeFrames,
        reference_m: np.ndarray,
        masses: Any,
        allocation: DipoleAllocation,
        law: str,
        period_s: float,
        omega0_body: np.ndarray,
        k_bdot_Nms_T2: float = 0.0,
        q_ref_wxyz: np.ndarray | None = None,
        Pq_Nm: np.ndarray | None = None,
        Pw_Nms: np.ndarray | None = None,
        inertia_kgm2: np.ndarray | None = None,
        mu_m3_s2: float | None = None,
        loops: LoopLorentzLoad | None = None,
    ) -> None:
        if law not in ("bdot", "quat_pd"):
            raise ValueError(f"law: must be 'bdot' or 'quat_pd', got {law!r}")
        if not (np.isfinite(period_s) and period_s > 0):
            raise ValueError(f"period_s: must be > 0 s, got {period_s!r}")
        self.nodes = nodes
        self.masses = masses
        self.fit = BestFitRotation(np.asarray(reference_m, dtype=float))
        self.allocation = allocation
        self.loops = loops
        self.law = law
        self.period_s = float(period_s)
        self.omega0_body = np.asarray(omega0_body, dtype=float)
        self.k = float(k_bdot_Nms_T2)
        self.q_ref = None if q_ref_wxyz is None else np.asarray(q_ref_wxyz, dtype=float) / np.linalg.norm(q_ref_wxyz)
        self.Pq = None if Pq_Nm is None else np.asarray(Pq_Nm, dtype=float)
        self.Pw = None if Pw_Nms is None else np.asarray(Pw_Nms, dtype=float)
        self.inertia = None if inertia_kgm2 is None else np.asarray(inertia_kgm2, dtype=float)
        self.mu = mu_m3_s2
        self._R_prev: np.ndarray | None = None
        self._t_prev = 0.0
        self.stats = np.zeros(2, dtype=np.int64)

    def estimate(self, state: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Best-fit rotation ``R``, body rate ``ω`` [rad/s] and centre of mass [m] at ``state``
        (updates the stored previous rotation: once per sample)."""
        x = self.nodes.positions(state.pos, state.xquat)
        R, _ = self.fit(x)
        if self._R_prev is None:
            omega = self.omega0_body.copy()
        else:
            dt = float(state.t) - self._t_prev
            omega = step_rate(self._R_prev, R, dt, "log") if dt > 0 else np.zeros(3)
        self._R_prev = R
        self._t_prev = float(state.t)
        com = self.masses.center_of_mass(self.masses.frames.positions(state.pos, state.xquat))
        return R, omega, com

    def reference_torque(
        self, R: np.ndarray, omega: np.ndarray, B_body: np.ndarray, com: np.ndarray, env: Any
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(T_ref [N m, body axes], q_err)`` of the law."""
        if self.law == "bdot":
            return bdot_torque(omega, B_body, k_Nms_T2=self.k), np.array([1.0, 0.0, 0.0, 0.0])
        q_e = error_quaternion(self.q_ref, quat_from_matrix(R))
        comp = None
        if self.mu is not None:
            r_b = R.T @ (np.asarray(env.r_ref_eci, dtype=float) + com)
            comp = gg_compensation_torque(r_b, self.inertia, mu=self.mu)
        T = quaternion_feedback_torque(q_e, omega, Pq_Nm=self.Pq, Pw_Nms=self.Pw, gg_comp_body=comp)
        return T, q_e

    def actuator_matrix(self, state: Any, R: np.ndarray) -> np.ndarray:
        """``D`` (3 × (R + L)) [A m²], body axes: the rods' columns ``m_max,r r̂_r`` then the current
        loops' ``I_max,L Rᵀ a_L`` with their vector areas ``a_L = ½ Σ x_a × x_b`` at ``state``'s
        node positions (module docstring, step 5); ``R`` the sampled rotation, body → world. The
        rods' ``D`` alone without loops."""
        if self.loops is None:
            return self.allocation.D
        I_max = self.loops.loops.current_max_A
        a_body = self.loops.vector_areas(self.loops.node_positions(state)) @ R  # rows Rᵀ a_L
        return np.hstack([self.allocation.D, (a_body * I_max[:, None]).T])

    def update(self, state: Any) -> DipoleCommand:
        """One control sample: state → :class:`DipoleCommand`."""
        if state.env is None:
            raise ValueError("state.env: the rod controller needs an environment sample (B_eci)")
        R, omega, com = self.estimate(state)
        B_body = R.T @ np.asarray(state.env.B_eci, dtype=float)
        T_ref, q_e = self.reference_torque(R, omega, B_body, com, state.env)
        if self.loops is None:
            u, saturated = self.allocation(T_ref, B_body)
            dipole = self.allocation.D @ u
            currents = np.zeros(0)
        else:
            D = self.actuator_matrix(state, R)
            v, saturated = least_norm_activations(np.linalg.pinv(D, rcond=LOOP_PINV_RCOND), T_ref, B_body)
            n_rods = self.allocation.D.shape[1]
            u, currents = v[:n_rods], v[n_rods:] * self.loops.loops.current_max_A
            dipole = D @ v
        self.stats[0] += 1
        self.stats[1] += saturated
        return DipoleCommand(
            t=float(state.t),
            activation=u,
            torque_ref_body=np.asarray(T_ref, dtype=float),
            torque_alloc_body=cross3(dipole, B_body),
            dipole_body=dipole,
            saturated=bool(saturated),
            R=R,
            omega_body=omega,
            B_body=B_body,
            com_world=com,
            q_err=np.asarray(q_e, dtype=float),
            counts=self.stats.copy(),
            currents_A=currents,
        )
