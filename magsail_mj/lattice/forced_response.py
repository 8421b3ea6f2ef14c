r"""Linear modal forced response of a free lattice with zero damping (exact between samples).

Linearised about the undeformed state (the stiffness and mass of :mod:`magsail_mj.lattice.modes`),
the body-frame displacement :math:`\mathbf u=\Phi\mathbf q` of a lattice under external nodal
loads :math:`\mathbf F(t)` obeys, mode by mode (M-orthonormal columns :math:`\boldsymbol\phi_n`,
:math:`\Phi^T\mathbf M\Phi=\mathbf I`),

.. math:: \ddot q_n+\omega_n^2q_n=f_n(t),\qquad f_n=\boldsymbol\phi_n^T\mathbf F\quad[\mathrm{N\,kg^{-1/2}}].

Rigid modes (:math:`\omega_n=0`) carry the attitude motion and are left out; the inertial load of
the rigid angular acceleration, :math:`-m_i\dot{\boldsymbol\omega}\times\mathbf r_i`, is a
rigid-rotation field and so has no elastic component.

Between two samples :math:`t_k` and :math:`t_{k+1}=t_k+h` the load is held (``hold="zero"``:
:math:`f=f_k`) or interpolated linearly (``hold="linear"``: :math:`f=f_k+g\tau`,
:math:`g=(f_{k+1}-f_k)/h`). The particular solution :math:`f(\tau)/\omega^2` of a load that is
linear in :math:`\tau` is exact, so with :math:`c=\cos\omega h`, :math:`s=\sin\omega h`
(Duhamel's integral in closed form; no step-size limit):

.. math::
   q_{k+1}=(q_k-f_k/\omega^2)\,c+(\dot q_k-g/\omega^2)\,s/\omega+f_{k+1}/\omega^2,\\
   \dot q_{k+1}=-(q_k-f_k/\omega^2)\,\omega s+(\dot q_k-g/\omega^2)\,c+g/\omega^2,

with :math:`g=0` and :math:`f_{k+1}\to f_k` for the zero-order hold. Without damping the modal
energy :math:`E_n=\tfrac12\dot q_n^2+\tfrac12\omega_n^2q_n^2` [J] changes only by the work of the
load, :math:`\int f_n\dot q_n\,dt` (for the zero-order hold exactly :math:`\sum_kf_k\,(q_{k+1}-q_k)`).
The strain energy of mode ``n`` is :math:`\tfrac12\omega_n^2q_n^2` [J]; the modal amplitudes are in
:math:`\mathrm{kg^{1/2}\,m}`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

__all__ = ["Hold", "ModalResponse", "modal_forces", "undamped_modal_response", "modal_displacement"]

Hold = Literal["zero", "linear"]
HOLDS: tuple[str, ...] = ("zero", "linear")


@dataclass(frozen=True)
class ModalResponse:
    """Modal response at the load samples.

    Attributes:
      t: ``(T,)`` sample times [s].
      omega: ``(K,)`` circular frequencies [rad/s] of the modes.
      q: ``(T, K)`` modal amplitudes [kg^1/2 m].
      qdot: ``(T, K)`` their rates [kg^1/2 m/s].
    """

    t: np.ndarray
    omega: np.ndarray
    q: np.ndarray
    qdot: np.ndarray

    @property
    def strain_energy_J(self) -> np.ndarray:
        """``(T, K)`` strain energy ½ ω² q² of every mode [J]."""
        return 0.5 * self.omega**2 * self.q**2

    @property
    def kinetic_energy_J(self) -> np.ndarray:
        """``(T, K)`` kinetic energy ½ q̇² of every mode [J]."""
        return 0.5 * self.qdot**2

    @property
    def energy_J(self) -> np.ndarray:
        """``(T, K)`` modal energy ½ q̇² + ½ ω² q² [J]."""
        return self.strain_energy_J + self.kinetic_energy_J


def modal_forces(phi: np.ndarray, forces: np.ndarray) -> np.ndarray:
    r"""Modal loads :math:`f_n=\boldsymbol\phi_n^T\mathbf F` [N kg^-1/2].

    Args:
      phi: ``(3 n, K)`` mode shapes (node-major, body frame) [kg^-1/2].
      forces: ``(T, n, 3)`` or ``(T, 3 n)`` nodal loads in the same frame [N].

    Returns:
      ``(T, K)``.
    """
    phi = np.asarray(phi, dtype=float)
    F = np.asarray(forces, dtype=float)
    F = F.reshape(F.shape[0], -1)
    if phi.ndim != 2 or F.shape[1] != phi.shape[0]:
        raise ValueError(
            f"forces: expected (T, {phi.shape[0] // 3}, 3) to match phi {phi.shape}, got {np.shape(forces)}"
        )
    return F @ phi


def _check_inputs(omega, t, f) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    t = np.asarray(t, dtype=float)
    f = np.asarray(f, dtype=float)
    if omega.ndim != 1 or not np.all(omega > 0) or not np.all(np.isfinite(omega)):
        raise ValueError("omega: expected a 1-D array of finite frequencies > 0 [rad/s] (leave rigid modes out)")
    if t.ndim != 1 or t.size < 1 or np.any(np.diff(t) <= 0):
        raise ValueError(f"t: expected strictly increasing sample times, got shape {t.shape}")
    if f.ndim == 1 and omega.size == 1:
        f = f[:, None]
    if f.shape != (t.size, omega.size):
        raise ValueError(f"f: expected shape ({t.size}, {omega.size}) (samples, modes), got {f.shape}")
    return omega, t, f


def undamped_modal_response(
    omega: np.ndarray,
    t: np.ndarray,
    f: np.ndarray,
    *,
    hold: Hold = "linear",
    q0: np.ndarray | None = None,
    qdot0: np.ndarray | None = None,
) -> ModalResponse:
    r"""Exact response of undamped oscillators :math:`\ddot q+\omega^2q=f(t)` (module docstring).

    Args:
      omega: ``(K,)`` circular frequencies [rad/s], all > 0.
      t: ``(T,)`` strictly increasing sample times [s] (any spacing).
      f: ``(T, K)`` modal loads at the samples (``(T,)`` for one mode).
      hold: ``"linear"`` (interpolate between samples) or ``"zero"`` (hold each sample until
        the next).
      q0, qdot0: ``(K,)`` initial amplitudes and rates at ``t[0]`` (default at rest).

    Returns:
      the :class:`ModalResponse` at the samples.
    """
    if hold not in HOLDS:
        raise ValueError(f"hold: must be one of {list(HOLDS)}, got {hold!r}")
    omega, t, f = _check_inputs(omega, t, f)
    K = omega.size
    q = np.empty((t.size, K))
    qd = np.empty((t.size, K))
    q[0] = np.zeros(K) if q0 is None else np.broadcast_to(np.asarray(q0, dtype=float), (K,))
    qd[0] = np.zeros(K) if qdot0 is None else np.broadcast_to(np.asarray(qdot0, dtype=float), (K,))
    w2 = omega**2
    for k, h in enumerate(np.diff(t)):
        c, s = np.cos(omega * h), np.sin(omega * h)
        f_end = f[k + 1] if hold == "linear" else f[k]
        g = (f_end - f[k]) / h
        a = q[k] - f[k] / w2
        b = qd[k] - g / w2
        q[k + 1] = a * c + b * s / omega + f_end / w2
        qd[k + 1] = -a * omega * s + b * c + g / w2
    return ModalResponse(t=t, omega=omega, q=q, qdot=qd)


def modal_displacement(phi: np.ndarray, q: np.ndarray) -> np.ndarray:
    r"""Nodal displacements :math:`\mathbf u=\Phi\mathbf q` [m], ``(T, n, 3)``, of ``phi``
    ``(3 n, K)`` [kg^-1/2] and amplitudes ``q`` ``(T, K)`` [kg^1/2 m]."""
    phi = np.asarray(phi, dtype=float)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if q.shape[1] != phi.shape[1]:
        raise ValueError(f"q: expected (T, {phi.shape[1]}) amplitudes for phi {phi.shape}, got {q.shape}")
    return (q @ phi.T).reshape(q.shape[0], -1, 3)
