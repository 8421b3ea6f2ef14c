r"""Rigid-body reference of a plate carrying a body-fixed dipole in a uniform field.

Euler's equations in body axes with the magnetic torque and the attitude as a rotation matrix
(body → world):

.. math::

    J\dot{\boldsymbol\omega} + \boldsymbol\omega\times J\boldsymbol\omega
        = \mathbf m_b\times(R^{\mathsf T}\mathbf B),\qquad \dot R = R\,[\boldsymbol\omega]_\times ,

integrated with SciPy's ``solve_ivp`` (DOP853, tight tolerances). In a uniform field this is a
pendulum: starting at rest with the dipole at ``θ₀`` from the field and the rotation about a
principal axis of moment ``J``, the period is ``T = 4 K(k) √(J / (m B))`` with modulus
``k = sin(θ₀/2)`` (SciPy's ``ellipk`` takes the parameter ``k²``).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.special import ellipk

__all__ = ["rigid_dipole_attitude", "pendulum_period"]


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rigid_dipole_attitude(
    t: np.ndarray,
    *,
    inertia: np.ndarray,
    dipole_body: np.ndarray,
    field_world: np.ndarray,
    R0: np.ndarray | None = None,
    omega0_body: np.ndarray | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
) -> tuple[np.ndarray, np.ndarray]:
    """Attitudes ``R(t)`` (T, 3, 3) and body rates (T, 3) of the rigid dipole plate at times ``t``.

    Args:
      t: increasing sample times [s], starting at 0.
      inertia: (3, 3) inertia tensor about the centre of mass, body axes [kg m²].
      dipole_body: (3,) body-fixed dipole [A m²].
      field_world: (3,) uniform field [T].
      R0, omega0_body: initial attitude (identity) and body rate (zero).
    """
    t = np.asarray(t, dtype=float)
    J = np.asarray(inertia, dtype=float)
    Jinv = np.linalg.inv(J)
    m = np.asarray(dipole_body, dtype=float)
    B = np.asarray(field_world, dtype=float)
    R0 = np.eye(3) if R0 is None else np.asarray(R0, dtype=float)
    w0 = np.zeros(3) if omega0_body is None else np.asarray(omega0_body, dtype=float)

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        R = y[:9].reshape(3, 3)
        w = y[9:]
        torque = np.cross(m, R.T @ B)
        dw = Jinv @ (torque - np.cross(w, J @ w))
        return np.concatenate([(R @ _hat(w)).ravel(), dw])

    sol = solve_ivp(
        rhs,
        (float(t[0]), float(t[-1])),
        np.concatenate([R0.ravel(), w0]),
        t_eval=t,
        method="DOP853",
        rtol=rtol,
        atol=atol,
    )
    if not sol.success:
        raise RuntimeError(f"rigid reference integration failed: {sol.message}")
    R = sol.y[:9].T.reshape(-1, 3, 3)
    # re-orthonormalise (the integration drifts by ~rtol)
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt, sol.y[9:].T


def pendulum_period(*, inertia_axis: float, dipole: float, field: float, theta0_rad: float) -> float:
    """Period [s] of the rigid magnetic pendulum: ``4 K(sin²(θ₀/2)) √(J / (m B))``."""
    if not (inertia_axis > 0 and dipole > 0 and field > 0):
        raise ValueError(f"inertia_axis, dipole, field: must be > 0, got {inertia_axis!r}, {dipole!r}, {field!r}")
    if not 0 < theta0_rad < np.pi:
        raise ValueError(f"theta0_rad: must be in (0, π), got {theta0_rad!r}")
    return float(4.0 * ellipk(np.sin(theta0_rad / 2.0) ** 2) * np.sqrt(inertia_axis / (dipole * field)))
