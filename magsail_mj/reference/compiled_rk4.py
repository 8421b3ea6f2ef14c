r"""The spring–dashpot lattice's RK4 compiled from C: the compiled counterpart of the NumPy reference.

Same equations and the same classical RK4 as :mod:`magsail_mj.reference.numpy_rk4` (Robb et al.
2022a, Sec. 2.1; strut law ``F = k(ℓ − l0) + γ (ṙ·r̂)`` along ``r̂``), with the distributed strut
torque of :class:`~magsail_mj.loads.strut_torque.StrutTorqueLoad` (``"local"`` torque axis)
evaluated at every stage, written as one C loop over struts (``magsail_mj/compiled/lattice_rk4.c``,
built once by :func:`magsail_mj.compiled.build_library`, called through ``ctypes``). The torque
command must be a function of time alone, ``τ(t)`` [N m, body axes] (the open-loop profiles of the
distributed-vs-centralised experiment); it is evaluated in Python, vectorised, at ``t``,
``t + δt/2`` and ``t + δt`` of every step before the C loop runs.

The C sums follow the NumPy reference's order, so the two differ only by the rounding of square
roots and dot products (``tests/test_compiled_reference.py``). Units: SI, world axes.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Callable

import numpy as np

from magsail_mj.compiled import build_library
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.reference.numpy_rk4 import SpringMassLattice

__all__ = ["CompiledLattice", "StrutCouples", "TorqueOfTime"]

LIBRARY = "lattice_rk4"
"""The C source's name in :data:`magsail_mj.compiled.SOURCE_DIR`."""

TorqueOfTime = Callable[[np.ndarray], np.ndarray]
"""``τ(t)``: times (T,) [s] → body torque commands (T, 3) [N m]."""

_i32 = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
_f64 = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_lib: ctypes.CDLL | None = None


def _library() -> ctypes.CDLL:
    """The built library with the argument types of ``magsail_lattice_rk4`` (built once per process)."""
    global _lib
    if _lib is None:
        lib = ctypes.CDLL(str(build_library(LIBRARY)))
        f = lib.magsail_lattice_rk4
        f.restype = ctypes.c_int
        f.argtypes = [
            ctypes.c_int, ctypes.c_int, _i32, _f64, _f64, _f64, _f64,
            ctypes.c_int, _i32, _f64, _f64,
            ctypes.c_double, ctypes.c_long, _f64, _f64, _f64, ctypes.c_long, _f64,
        ]  # fmt: skip
        _lib = lib
    return _lib


@dataclass(frozen=True)
class StrutCouples:
    """The distributed strut torque in the C layout.

    Attributes:
      ends: (M, 6) int32 node indices ``i, j, i_bot, i_top, j_bot, j_top`` of the actuated struts.
      shares: (M, 3) shares ``w1, w2, w3`` of ``τ₁, τ₂, τ₃`` (:meth:`StrutTorqueLoad.strut_torques`).
      command: ``τ(t)`` (:data:`TorqueOfTime`).
    """

    ends: np.ndarray
    shares: np.ndarray
    command: TorqueOfTime

    @classmethod
    def from_load(cls, load: StrutTorqueLoad, command: TorqueOfTime) -> StrutCouples:
        """The couples of ``load`` (its node rows less its ``body_offset``) with the time command ``command``.

        Raises:
          ValueError: ``load.torque_axis`` is not ``"local"`` (the best-fit axis is not compiled).
        """
        if load.torque_axis != "local":
            raise ValueError(f"torque_axis: the compiled reference has the 'local' axis only, got {load.torque_axis!r}")
        cols = (load.i, load.j, load.i_bot, load.i_top, load.j_bot, load.j_top)
        ends = np.ascontiguousarray(np.stack(cols, axis=1) - load.body_offset, dtype=np.int32)
        shares = np.ascontiguousarray(np.stack((load.w1, load.w2, load.w3), axis=1), dtype=float)
        return cls(ends=ends, shares=shares, command=command)


class CompiledLattice:
    """RK4 of a :class:`SpringMassLattice` (and optional :class:`StrutCouples`) in C (module docstring).

    Args:
      system: the lattice (masses, struts, k, l0, γ, clamped nodes).
      couples: the distributed strut torque, or ``None`` for the springs alone.
    """

    def __init__(self, system: SpringMassLattice, *, couples: StrutCouples | None = None) -> None:
        self.system = system
        self.couples = couples
        self.n = int(system.n)
        self._ends = np.ascontiguousarray(system.struts, dtype=np.int32)
        self._k = np.ascontiguousarray(system.k, dtype=float)
        self._l0 = np.ascontiguousarray(system.l0, dtype=float)
        self._gamma = np.ascontiguousarray(system.gamma, dtype=float)
        self._inv_m = np.ascontiguousarray(system._inv_m, dtype=float)
        self._work = np.zeros(16 * 3 * self.n)
        if couples is None:
            self._act, self._w = np.zeros(6, dtype=np.int32), np.zeros(3)
        else:
            self._act, self._w = couples.ends, couples.shares
        self._lib = _library()

    def commands(self, *, t0: float, dt: float, n_steps: int) -> np.ndarray:
        """(n_steps, 3, 3) ``τ`` at ``t``, ``t + dt/2``, ``t + dt`` of every step, ``t = t0 + step·dt``
        (the times the NumPy reference evaluates its load at) [N m]."""
        if self.couples is None:
            return np.zeros((1, 3, 3))
        t = t0 + np.arange(n_steps) * dt
        times = np.stack((t, t + 0.5 * dt, t + dt), axis=1).reshape(-1)
        tau = np.asarray(self.couples.command(times), dtype=float)
        if tau.shape != (times.size, 3):
            raise ValueError(f"command: expected ({times.size}, 3) torques for {times.size} times, got {tau.shape}")
        return np.ascontiguousarray(tau.reshape(n_steps, 3, 3))

    def run(
        self,
        x0: np.ndarray,
        v0: np.ndarray,
        *,
        dt: float,
        n_steps: int,
        t0: float = 0.0,
        record_every: int = 0,
        tau: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """``n_steps`` RK4 steps of ``dt`` [s] from ``(x0, v0)`` at ``t0``.

        ``tau``: precomputed :meth:`commands` (else computed here). Returns the final ``(x, v)``
        and, when ``record_every > 0``, ``{"t", "x"}`` every ``record_every`` steps and at the end
        (the records of :func:`~magsail_mj.reference.numpy_rk4.rk4_run`).
        """
        if n_steps < 0 or record_every < 0:
            raise ValueError(f"n_steps, record_every: must be >= 0, got {n_steps}, {record_every}")
        x = np.array(x0, dtype=float, order="C")
        v = np.array(v0, dtype=float, order="C")
        if x.shape != (self.n, 3) or v.shape != (self.n, 3):
            raise ValueError(f"x0, v0: expected ({self.n}, 3), got {x.shape}, {v.shape}")
        if tau is None:
            tau = self.commands(t0=t0, dt=dt, n_steps=n_steps)
        rows = (-(-n_steps // record_every) + 1) if record_every else 1
        rec = np.zeros((rows, self.n, 3))
        M = 0 if self.couples is None else int(self._act.shape[0])
        rc = self._lib.magsail_lattice_rk4(
            self.n, int(self._k.size), self._ends, self._k, self._l0, self._gamma, self._inv_m,
            M, self._act, self._w, tau, float(dt), int(n_steps), x, v, self._work, int(record_every), rec,
        )  # fmt: skip
        if rc != 0:
            raise ValueError(f"n_steps: the C loop refused the sizes (n {self.n}, steps {n_steps})")
        if not record_every:
            return x, v, {}
        t = t0 + np.minimum(np.arange(rows) * record_every, n_steps) * dt
        return x, v, {"t": t, "x": rec}
