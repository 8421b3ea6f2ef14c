"""Gravity loads of the orbit-following world: exact tidal forces and the classical
gravity-gradient torque.

The MuJoCo world rides the reference orbit r_ref(t) with axes parallel to ECI, so a
body at world position x feels, besides the forces of the structure, only the tidal acceleration

    a(x) = g(r_ref + x) − g(r_ref)

(two-body, plus J2 when the reference orbit has it), computed without cancellation by
:func:`magsail_mj.environment.gravity.tidal_acceleration`. The force m a is applied at the body
origin (= centre of mass for particle bodies). Robb et al. 2022a; Yoo et al. 2016, Eq. 12.

:class:`GravityGradientTorqueLoad` applies instead the classical torque 3μ/r³ û × (I û) on one
rigid body (valid for rigid single bodies only).
"""

from __future__ import annotations

import math

import numpy as np

from magsail_mj.checks import is_symmetric
from magsail_mj.environment.constants import J2_EARTH, MU_EARTH, R_J2
from magsail_mj.quaternion import quat_to_matrix
from magsail_mj.environment.gravity import _q_and_f, gravity_gradient_torque, tidal_acceleration

from magsail_mj.loads.base import StepState

__all__ = ["TidalGravityLoad", "GravityGradientTorqueLoad", "gravity_gradient_torque"]


def _selector(ids: np.ndarray) -> slice | np.ndarray:
    """A slice when ``ids`` are consecutive (cheaper indexing), else the index array."""
    if len(ids) and np.all(np.diff(ids) == 1):
        return slice(int(ids[0]), int(ids[-1]) + 1)
    return ids


class TidalGravityLoad:
    """Exact tidal force m_i [g(r_ref + x_i) − g(r_ref)] on each body (world = ECI axes).

    Args:
      body_ids: (n,) MuJoCo body indices (unique; e.g. ``np.arange(1, 801)`` for a lattice).
      masses: (n,) body masses [kg].
      mu: gravitational parameter [m³/s²]; j2: include the J2 term (only with a J2 reference
        orbit); J2, R_j2: J2 coefficient and its radius [m].

    ``add`` reads ``state.pos`` (body origins) and ``state.env.r_ref_eci``.
    """

    name = "tidal_gravity"

    def __init__(
        self, body_ids, masses, *, mu: float = MU_EARTH, j2: bool = False, J2: float = J2_EARTH, R_j2: float = R_J2
    ) -> None:
        ids = np.asarray(body_ids, dtype=np.int64).ravel()
        m = np.asarray(masses, dtype=float).ravel()
        if ids.shape != m.shape:
            raise ValueError(f"masses: need one mass per body id ({len(ids)}), got {len(m)}")
        if len(np.unique(ids)) != len(ids):
            raise ValueError("body_ids: must be unique")
        if np.any(m < 0):
            raise ValueError("masses: must be >= 0 kg")
        self.body_ids = ids
        self.masses = m
        self._sel = _selector(ids)
        self._m_col = m[:, None]
        self.mu, self.j2, self.J2, self.R_j2 = float(mu), bool(j2), float(J2), float(R_j2)

    @classmethod
    def from_environment(cls, env, body_ids, masses) -> "TidalGravityLoad":
        """Use the environment's μ and J2 setting (``env.gravity_params``)."""
        return cls(body_ids, masses, **env.gravity_params)

    def accelerations(self, r_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Tidal accelerations (n, 3) [m/s²] at world positions ``x`` for reference point ``r_ref``."""
        return tidal_acceleration(r_ref, x, mu=self.mu, j2=self.j2, J2=self.J2, R=self.R_j2)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add m_i a(x_i) to the force rows of ``xfrc`` (world frame)."""
        r = state.env.r_ref_eci
        x = state.pos[self._sel]
        if self.j2:
            xfrc[self._sel, :3] += self._m_col * self.accelerations(r, x)
            return
        # two-body fast path: the same formula as tidal_acceleration with m μ/|r|³ folded in
        r2 = float(r @ r)
        _, f = _q_and_f(r, x, r2)
        k = (self.mu / (r2 * math.sqrt(r2))) * self._m_col[:, 0] / (1.0 + f)
        F = (k * f)[:, None] * r
        F -= k[:, None] * x
        xfrc[self._sel, :3] += F


class GravityGradientTorqueLoad:
    """Classical gravity-gradient torque on one rigid body (Eq. 12):

        T = 3μ/|r|³ û × (I_w û),   r = r_ref + x_body,  I_w = R I_body Rᵀ,

    with R from ``state.xquat`` (body → world) and I_body the inertia about the centre of mass in
    body axes. The body origin must be its centre of mass. Adds the world-frame torque.
    """

    name = "gravity_gradient_torque"

    def __init__(self, body_id: int, inertia_body, *, mu: float = MU_EARTH) -> None:
        I = np.asarray(inertia_body, dtype=float)
        if I.shape == (3,):
            I = np.diag(I)
        if I.shape != (3, 3) or not is_symmetric(I):
            raise ValueError(
                f"inertia_body: must be a finite symmetric (3, 3) tensor or 3 principal moments, got shape {I.shape}"
            )
        self.body_id = int(body_id)
        self.inertia_body = I
        self.mu = float(mu)

    def torque_world(self, state: StepState) -> np.ndarray:
        """The world-frame torque [N m] at this state."""
        R = quat_to_matrix(state.xquat[self.body_id], normalise=True)
        I_w = R @ self.inertia_body @ R.T
        r = state.env.r_ref_eci + state.pos[self.body_id]
        return gravity_gradient_torque(r, I_w, mu=self.mu)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        xfrc[self.body_id, 3:] += self.torque_world(state)
