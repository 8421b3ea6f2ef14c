r"""Quaternion error feedback with gravity-gradient compensation for the rod array.

Conventions: quaternions scalar-first Hamilton ``[w, x, y, z]``; ``q`` maps body components to
inertial (ECI = world) components, like the rotation matrix ``R`` of the best-fit attitude.

**Error quaternion** (Robb et al. 2022a; we correct the paper's ``q_err = q_ref q_t*``, whose
vector part points *towards* the target so that ``−P_q q_err`` pushes away from it):

.. math:: q_e = q_{\text{ref}}^{*}\otimes q_t,\qquad q_{e,0}<0\ \Rightarrow\ q_e\leftarrow -q_e

(the current attitude relative to the target, in body components; the sign flip takes the
shortest path).

**Reference torque** (paper Eqs. 20, 22 with diagonal gains; body components, N m):

.. math:: \mathbf T_{\text{ref}} = -\mathcal P_q\,\mathbf q_{e,\text{vec}} - \mathcal P_\omega\,\boldsymbol\omega
          - \frac{3\mu}{r^5}\,\mathbf r_b\times\mathcal I\,\mathbf r_b ,

``P_q = diag(10, 50, 1)`` N m, ``P_ω = diag(1600, 8000, 800)`` N m s by default (the listed values),
``ω`` the backward-difference body rate, ``r_b = Rᵀ (r_ref + x_c)`` the
centre-of-mass position from the Earth's centre in body components and ``𝓘`` the
particle-set inertia of Eq. 21 (computed, not the printed 1893/2867 kg m²,
which remain selectable). The last term is minus the classical gravity-gradient torque (Eq. 14),
so a rigid body's gravity-gradient torque is cancelled exactly when the allocation delivers
``T_ref``.

:class:`QuaternionPD` is the same feedback without the compensation, written against the typed
command set: it knows nothing of the spacecraft, reads the attitude and body rate from the
:class:`~magsail_mj.loads.base.StepState` through an injected attitude sensor and returns a
:class:`~magsail_mj.commands.BodyTorque` that any body-torque actuator
(:mod:`magsail_mj.loads.body_torque_actuators`) turns into forces.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence, Unpack

import numpy as np

from magsail_mj.checks import is_symmetric
from magsail_mj.commands import BodyTorque
from magsail_mj.control.reflector_pitch import pitch_gains
from magsail_mj.control.rod_attitude import RodAttitudeController, RodControllerOptions
from magsail_mj.environment.constants import MU_EARTH
from magsail_mj.quaternion import quat_from_matrix
from magsail_mj.quaternion import error_quaternion
from magsail_mj.vec3 import cross3

__all__ = [
    "gg_compensation_torque",
    "quaternion_feedback_torque",
    "QuaternionFeedbackRodController",
    "QuaternionPD",
]


def _unit_quat(q: Sequence[float], name: str) -> np.ndarray:
    a = np.asarray(q, dtype=float)
    if a.shape != (4,) or not np.all(np.isfinite(a)) or not np.linalg.norm(a) > 0:
        raise ValueError(f"{name}: expected a non-zero quaternion [w, x, y, z], got {q!r}")
    return a / np.linalg.norm(a)


def gg_compensation_torque(r_body: np.ndarray, inertia: np.ndarray, *, mu: float = MU_EARTH) -> np.ndarray:
    r"""Compensation term ``−3μ/r⁵ r_b × (𝓘 r_b)`` [N m] (Eq. 22).

    Args:
      r_body: (3,) centre-of-mass position from the Earth's centre in body components [m].
      inertia: (3,) principal moments or (3, 3) tensor about the centre of mass, body axes [kg m²].
      mu: gravitational parameter [m³/s²].

    Equals minus :func:`magsail_mj.environment.gravity.gravity_gradient_torque` (tested).
    """
    r = np.asarray(r_body, dtype=float)
    I = np.asarray(inertia, dtype=float)
    I = np.diag(I) if I.shape == (3,) else I
    if r.shape != (3,) or I.shape != (3, 3):
        raise ValueError(f"r_body, inertia: expected (3,) and (3,) or (3, 3), got {r.shape}, {I.shape}")
    r2 = float(r @ r)
    if not r2 > 0:
        raise ValueError("r_body: the centre of mass must not be at the Earth's centre")
    return -3.0 * mu / (r2 * r2 * np.sqrt(r2)) * cross3(r, I @ r)


def quaternion_feedback_torque(
    q_e: np.ndarray,
    omega_body: np.ndarray,
    *,
    Pq_Nm: Sequence[float],
    Pw_Nms: Sequence[float],
    gg_comp_body: np.ndarray | None = None,
) -> np.ndarray:
    r"""``T_ref = −P_q q_{e,vec} − P_ω ω (+ gg_comp_body)`` [N m], diagonal gains.

    Args:
      q_e: (4,) error quaternion of :func:`error_quaternion`.
      omega_body: (3,) body rate [rad/s].
      Pq_Nm: diagonal of ``P_q`` [N m]; Pw_Nms: diagonal of ``P_ω`` [N m s].
      gg_comp_body: (3,) compensation term of :func:`gg_compensation_torque`, or ``None``.
    """
    T = -np.asarray(Pq_Nm, dtype=float) * np.asarray(q_e, dtype=float)[1:] - np.asarray(
        Pw_Nms, dtype=float
    ) * np.asarray(omega_body, dtype=float)
    if gg_comp_body is not None:
        T = T + gg_comp_body
    return T


class QuaternionFeedbackRodController(RodAttitudeController):
    """Quaternion feedback + gravity-gradient compensation feeding the rod allocation.

    Args:
      q_ref_wxyz: target attitude (body → inertial, scalar first).
      Pq_Nm, Pw_Nms: gain diagonals (default the paper's (10, 50, 1) N m and (1600, 8000, 800) N m s).
      gg_comp: include the gravity-gradient compensation term.
      inertia_kgm2: (3,) moments or (3, 3) tensor used by the compensation [kg m²] (Eq. 21 by
        default, computed by the caller from the undeformed particle set, Eq. 21).
      mu: gravitational parameter [m³/s²].
      reference_nodes, masses, node_bodies, distributor, period_s, omega0_body, rate_method: see
        :class:`~magsail_mj.control.rod_attitude.RodAttitudeController`.

    ``RodCommand.extra`` holds ``q_err`` (4,) and ``gg_comp_body`` (3,) [N m].
    """

    law = "quat_pd"

    def __init__(
        self,
        *,
        q_ref_wxyz: Sequence[float],
        inertia_kgm2: Sequence[float] | np.ndarray,
        Pq_Nm: Sequence[float] = (10.0, 50.0, 1.0),
        Pw_Nms: Sequence[float] = (1600.0, 8000.0, 800.0),
        gg_comp: bool = True,
        mu: float = MU_EARTH,
        **base: Unpack[RodControllerOptions],
    ) -> None:
        super().__init__(**base)
        self.q_ref = _unit_quat(q_ref_wxyz, "q_ref_wxyz")
        for name, g in (("Pq_Nm", Pq_Nm), ("Pw_Nms", Pw_Nms)):
            a = np.asarray(g, dtype=float)
            if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"{name}: expected 3 gains >= 0, got {g!r}")
        self.Pq = np.asarray(Pq_Nm, dtype=float)
        self.Pw = np.asarray(Pw_Nms, dtype=float)
        I = np.asarray(inertia_kgm2, dtype=float)
        I = np.diag(I) if I.shape == (3,) else I
        if I.shape != (3, 3) or not is_symmetric(I):
            raise ValueError(
                f"inertia_kgm2: expected 3 moments or a symmetric (3, 3) tensor [kg m²], "
                f"got shape {np.shape(inertia_kgm2)}"
            )
        self.inertia = I
        self.gg_comp = bool(gg_comp)
        if not (np.isfinite(mu) and mu > 0):
            raise ValueError(f"mu: must be > 0 m³/s², got {mu!r}")
        self.mu = float(mu)

    def reference_torque(
        self, *, t: float, R: np.ndarray, omega_body: np.ndarray, B_body: np.ndarray, com_world: np.ndarray, env: Any
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """``T_ref`` of the module docstring; ``extra = {"q_err", "gg_comp_body"}``."""
        q_e = error_quaternion(self.q_ref, quat_from_matrix(R))
        comp = np.zeros(3)
        if self.gg_comp:
            r_b = R.T @ (np.asarray(env.r_ref_eci, dtype=float) + com_world)
            comp = gg_compensation_torque(r_b, self.inertia, mu=self.mu)
        T = quaternion_feedback_torque(q_e, omega_body, Pq_Nm=self.Pq, Pw_Nms=self.Pw, gg_comp_body=comp)
        return T, {"q_err": q_e, "gg_comp_body": comp}


AttitudeSensor = Callable[[Any], tuple[np.ndarray, np.ndarray]]
"""``state → (q_wxyz (4,) body → world, ω (3,) body axes [rad/s])``; see
:func:`magsail_mj.loads.body_torque_actuators.attitude_sensor`."""


def _gain3(value: Sequence[float], name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"{name}: expected 3 gains >= 0, got {value!r}")
    return a


class QuaternionPD:
    r"""Body-torque quaternion PD, ``T = −P_q q_{e,vec} − P_ω ω`` [N m] (body axes), as a
    :class:`~magsail_mj.commands.BodyTorque`.

    It knows nothing of the spacecraft: each sample it asks ``sensor(state)`` for the attitude
    ``q`` (body → world, scalar first) and the body rate ``ω`` [rad/s], forms
    ``q_e = q_ref* ⊗ q`` (shortest path, :func:`~magsail_mj.quaternion.error_quaternion`) and calls
    :func:`quaternion_feedback_torque` (no gravity-gradient term).

    Args:
      sensor: ``state → (q_wxyz, omega_body_rad_s)`` (a rigid body's or a lattice's best fit).
      q_ref_wxyz: target attitude (body → world, scalar first; normalised).
      Pq_Nm: diagonal of ``P_q`` [N m]; Pw_Nms: diagonal of ``P_ω`` [N m s].
      period_s: control period [s] (the runner holds the command in between).

    Telemetry: ``q_err`` (4,) and ``omega_body`` (3,) of the last sample.
    """

    law = "quat_pd_body_torque"

    def __init__(
        self,
        *,
        sensor: AttitudeSensor,
        q_ref_wxyz: Sequence[float],
        Pq_Nm: Sequence[float],
        Pw_Nms: Sequence[float],
        period_s: float,
    ) -> None:
        if not callable(sensor):
            raise ValueError(f"sensor: expected a callable state → (q_wxyz, omega_body), got {sensor!r}")
        if not (np.isfinite(period_s) and period_s > 0):
            raise ValueError(f"period_s: must be > 0 s, got {period_s!r}")
        self.sensor = sensor
        self.q_ref = _unit_quat(q_ref_wxyz, "q_ref_wxyz")
        self.Pq = _gain3(Pq_Nm, "Pq_Nm")
        self.Pw = _gain3(Pw_Nms, "Pw_Nms")
        self.period_s = float(period_s)
        self.q_err = np.array([1.0, 0.0, 0.0, 0.0])
        self.omega_body = np.zeros(3)

    @classmethod
    def from_bandwidth(
        cls,
        *,
        sensor: AttitudeSensor,
        q_ref_wxyz: Sequence[float],
        inertia_kgm2: Sequence[float],
        omega_n_rad_s: float,
        zeta: float,
        period_s: float,
    ) -> "QuaternionPD":
        """Gains per axis ``P_q = 2 I ω_n²``, ``P_ω = 2 ζ ω_n I`` from principal moments ``inertia_kgm2``
        [kg m²] (:func:`~magsail_mj.control.reflector_pitch.pitch_gains`)."""
        Pq, Pw = pitch_gains(inertia_kgm2, omega_n_rad_s=omega_n_rad_s, zeta=zeta)
        return cls(sensor=sensor, q_ref_wxyz=q_ref_wxyz, Pq_Nm=Pq, Pw_Nms=Pw, period_s=period_s)

    def update(self, state: Any) -> BodyTorque:
        """One sample: the sensor's attitude and rate → :class:`~magsail_mj.commands.BodyTorque`."""
        q, omega = self.sensor(state)
        self.q_err = error_quaternion(self.q_ref, np.asarray(q, dtype=float))
        self.omega_body = np.asarray(omega, dtype=float)
        T = quaternion_feedback_torque(self.q_err, self.omega_body, Pq_Nm=self.Pq, Pw_Nms=self.Pw)
        return BodyTorque(torque_body_Nm=T)
