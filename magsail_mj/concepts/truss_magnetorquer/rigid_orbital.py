r"""Rigid-body counterpart of the orbital truss scenarios (a diagnostic).

The flexible runs (`concepts/truss_magnetorquer/orbital.py`) integrate 800 particles joined by struts. This
module keeps everything else of a scenario — the controller object with its allocation and
Lloyd selection, the rod dipoles, the IGRF field and the reference orbit — and replaces the
lattice by one rigid body with the particle inertia ``J`` (Eq. 21, body axes) in the
orbit-following frame (axes = ECI, so only the rotation matters):

.. math::

    J\dot{\boldsymbol\omega} = -\boldsymbol\omega\times J\boldsymbol\omega
        + R^{\mathsf T}(\mathbf m\times\mathbf B) + \frac{3\mu}{r^5}\,\mathbf r_b\times J\,\mathbf r_b,
    \qquad \dot q = \tfrac12\, q\otimes(0, \boldsymbol\omega),\qquad \mathbf r_b = R^{\mathsf T}\mathbf r_{ref},

with ``m`` the sum of the rod dipoles of the held polarity (the force pairs of a rigid rod sum to
``m × B``) and the classical gravity-gradient torque (``gravity_gradient = False``
drops it, as in the gravity-gradient ablation). Classical RK4 at ``dt`` with the control sample held over
the step, the field and orbit sampled at each stage. The controller sees the rigid particle
positions, so its best fit returns ``R`` exactly and its rate is the backward difference of the
rigid attitude.

If a manoeuvre fails the same way on this body as on the flexible lattice, the failure belongs
to the control law, its gains or the manoeuvre definition, not to the structure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Literal

import numpy as np

from magsail_mj.quaternion import error_quaternion, quat_mul
from magsail_mj.quaternion import quat_to_matrix as quat_to_matrix_wxyz
from magsail_mj.environment.gravity import gravity_gradient_torque
from magsail_mj.concepts.truss_magnetorquer.force_pair import VariantPairRodLoad

__all__ = ["RigidRun", "quat_to_matrix_wxyz", "rigid_rhs", "simulate_rigid"]


def rigid_rhs(
    q: np.ndarray,
    w: np.ndarray,
    *,
    J: np.ndarray,
    J_inv: np.ndarray,
    m_body: np.ndarray,
    B_eci: np.ndarray,
    r_ref_eci: np.ndarray,
    mu: float,
    gravity_gradient: bool,
    T_held_body: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(q̇, ω̇, T_ctrl_body, T_gg_body)`` of the module equations; ``m_body`` in body axes [A m²].

    ``T_held_body`` (N m, body axes) replaces the dipole torque ``m × B`` when given (the ideal
    actuators of :func:`simulate_rigid`).
    """
    R = quat_to_matrix_wxyz(q)
    T_mag = np.cross(m_body, R.T @ B_eci) if T_held_body is None else T_held_body
    if gravity_gradient:
        T_gg = gravity_gradient_torque(R.T @ r_ref_eci, J, mu=mu)
    else:
        T_gg = np.zeros(3)
    w_dot = J_inv @ (T_mag + T_gg - np.cross(w, J @ w))
    q_dot = 0.5 * quat_mul(q, np.array([0.0, w[0], w[1], w[2]]))
    return q_dot, w_dot, T_mag, T_gg


@dataclass
class RigidRun:
    """Samples (every ``record_every_s``) of a rigid run.

    Attributes:
      t: (T,) times [s]; q: (T, 4) attitude (w, x, y, z), body → ECI; omega: (T, 3) body rate
      [rad/s]; err_deg: (T,) error angle to the target [deg] (NaN without a target);
      saturated: (T,) either family saturated at the control sample; T_mag, T_gg: (T, 3) body
      torques [N m] (T_mag: the control torque actually applied); T_ref: (T, 3) reference torque [N m].
    """

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    err_deg: np.ndarray
    saturated: np.ndarray
    T_mag: np.ndarray
    T_gg: np.ndarray
    T_ref: np.ndarray


def simulate_rigid(
    *,
    controller: Any,
    rod_load: Any,
    environment: Any,
    nodes_body: np.ndarray,
    masses: np.ndarray,
    inertia: np.ndarray,
    q0_wxyz: np.ndarray,
    omega0_body: np.ndarray,
    duration_s: float,
    dt: float = 0.1,
    q_ref_wxyz: np.ndarray | None = None,
    gravity_gradient: bool = True,
    record_every_s: float = 10.0,
    actuation: Literal["rods", "ideal", "ideal_perp_B"] = "rods",
) -> RigidRun:
    """Run the rigid body with ``controller`` (a :class:`RodAttitudeController`) for ``duration_s``.

    Args:
      controller: updated every step with a state holding the rigid particle positions.
      rod_load: the :class:`MagnetorquerRodLoad` whose ``total_dipole_world`` turns a polarity
        into the total dipole (a :class:`~magsail_mj.concepts.truss_magnetorquer.force_pair.VariantPairRodLoad`
        with the printed pair turns the torque around, as its force pairs do).
      environment: :class:`~magsail_mj.environment.environment.Environment` (``sample(t)``).
      nodes_body: (n, 3) undeformed particle coordinates (the controller's reference nodes);
        particle ``i`` is body ``i + 1`` (body 0 is the world).
      masses: (n,) particle masses [kg]; inertia: (3, 3) inertia about their centre [kg m²].
      q0_wxyz, omega0_body: initial attitude and body rate.
      q_ref_wxyz: target attitude for the recorded error angle (``None``: no error angle).
      gravity_gradient: include the gravity-gradient torque.
      actuation: ``"rods"`` — the torque ``m × B`` of the held rod polarities (the scenario's
        actuators); ``"ideal"`` — the reference torque ``T_ref`` itself, held over the step (any
        direction, no saturation); ``"ideal_perp_B"`` — ``T_ref`` less its component along
        ``B`` (what an unsaturated dipole actuator can make, ``T ⊥ B``).
    """
    if actuation not in ("rods", "ideal", "ideal_perp_B"):
        raise ValueError(f"actuation: must be 'rods', 'ideal' or 'ideal_perp_B', got {actuation!r}")
    if dt <= 0 or duration_s <= 0:
        raise ValueError(f"dt and duration_s must be > 0, got dt={dt}, duration_s={duration_s}")
    sign = rod_load.sign if isinstance(rod_load, VariantPairRodLoad) else 1.0  # −1: the printed pair
    J = np.asarray(inertia, dtype=float)
    J_inv = np.linalg.inv(J)
    m = np.asarray(masses, dtype=float) * np.ones(len(nodes_body))
    p = np.asarray(nodes_body, dtype=float)
    p_c = p - (m @ p) / m.sum()
    mu = float(environment.mu)
    q = np.asarray(q0_wxyz, dtype=float) / np.linalg.norm(q0_wxyz)
    w = np.asarray(omega0_body, dtype=float).copy()
    n_steps = int(round(duration_s / dt))
    every = max(1, int(round(record_every_s / dt)))
    rec: dict[str, list] = {k: [] for k in ("t", "q", "omega", "err", "sat", "T_mag", "T_gg", "T_ref")}
    for k in range(n_steps + 1):
        t = k * dt
        env0 = environment.sample(t)
        R = quat_to_matrix_wxyz(q)
        pos = np.vstack([np.zeros(3), p_c @ R.T])  # body 0 is the world, as in MuJoCo's xpos
        cmd = controller.update(SimpleNamespace(t=t, pos=pos, env=env0))
        m_body = sign * (R.T @ rod_load.total_dipole_world(pos, cmd.polarity))
        T_held = None
        if actuation != "rods":
            T_held = np.array(cmd.torque_ref_body, dtype=float)
            if actuation == "ideal_perp_B":
                b = R.T @ env0.B_eci
                T_held -= (T_held @ b) / (b @ b) * b
        kw = dict(J=J, J_inv=J_inv, m_body=m_body, mu=mu, gravity_gradient=gravity_gradient, T_held_body=T_held)
        if k % every == 0:
            _, _, T_mag, T_gg = rigid_rhs(q, w, B_eci=env0.B_eci, r_ref_eci=env0.r_ref_eci, **kw)
            err = (
                math.degrees(
                    2
                    * math.atan2(
                        np.linalg.norm(error_quaternion(q_ref_wxyz, q)[1:]), abs(error_quaternion(q_ref_wxyz, q)[0])
                    )
                )
                if q_ref_wxyz is not None
                else math.nan
            )
            for key, value in (
                ("t", t),
                ("q", q.copy()),
                ("omega", w.copy()),
                ("err", err),
                ("sat", cmd.clipped1 or cmd.clipped2),
                ("T_mag", T_mag),
                ("T_gg", T_gg),
                ("T_ref", cmd.torque_ref_body),
            ):
                rec[key].append(value)
        if k == n_steps:
            break
        env_h, env_1 = environment.sample(t + 0.5 * dt), environment.sample(t + dt)
        stages = ((env0, 0.0), (env_h, 0.5), (env_h, 0.5), (env_1, 1.0))
        dq, dw, qs, ws = [], [], q, w
        for i, (env, _) in enumerate(stages):
            if i:
                h = dt * stages[i][1]
                qs, ws = q + h * dq[-1], w + h * dw[-1]
            a, b, _, _ = rigid_rhs(qs, ws, B_eci=env.B_eci, r_ref_eci=env.r_ref_eci, **kw)
            dq.append(a)
            dw.append(b)
        q = q + dt / 6 * (dq[0] + 2 * dq[1] + 2 * dq[2] + dq[3])
        q /= np.linalg.norm(q)
        w = w + dt / 6 * (dw[0] + 2 * dw[1] + 2 * dw[2] + dw[3])
    return RigidRun(
        t=np.array(rec["t"]),
        q=np.array(rec["q"]),
        omega=np.array(rec["omega"]),
        err_deg=np.array(rec["err"]),
        saturated=np.array(rec["sat"], dtype=bool),
        T_mag=np.array(rec["T_mag"]),
        T_gg=np.array(rec["T_gg"]),
        T_ref=np.array(rec["T_ref"]),
    )
