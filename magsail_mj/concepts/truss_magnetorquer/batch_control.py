r"""The truss's rod-array controller over a world axis: one batched best fit, each world's own law.

A control sample of the single run (:class:`~magsail_mj.control.rod_attitude.RodAttitudeController`,
Robb et al. 2022a, Eqs. 11–13) is, per world: the best-fit rotation ``R`` of the particles
(Kabsch: ``q̄ = w·q``, ``H = p_cᵀ q − (Σ p_c) q̄ᵀ``, ``H = U Σ Vᵀ``, ``R = V Uᵀ`` with the third
column of V negated where ``det R < 0``), the backward-difference body rate, ``B_b = Rᵀ B``, the
reference torque of the world's law, the allocation ``(N1, N2)`` and the Lloyd rod selection.

:class:`RodControlWorlds` does the best fit of every live world in one pass (one
:func:`numpy.matmul` per world for ``w·q`` and ``p_cᵀ q``, one batched
:func:`numpy.linalg.svd` and :func:`numpy.linalg.det`: the LAPACK and BLAS routines the single
run calls, on the same shapes, so each world's ``R`` equals its single run's bit for bit), then
hands each world's ``R`` to that world's own controller object and runs its ``update`` (rate,
law, allocation, counters, held :class:`~magsail_mj.control.rod_attitude.RodCommand`) unchanged:
a few tens of µs per world, against the best fit's ≈ 60 µs alone.

Worlds whose reference particle sets differ (another ``lattice.side_m``) are fitted in separate
passes. The schedule (``control.period_s``, ``sim.timestep_s``) is the same in every world, so the
sample index ``n_ctrl`` is one number: sample ``k`` is due at step ``s`` when
``s·δt ≥ k·period − 10⁻⁶ δt``, as :class:`magsail_mj.sim.Simulation` decides it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from magsail_mj.control.rod_attitude import RodAttitudeController, RodCommand
from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.loads.base import StepState

__all__ = ["RodControlWorlds", "WorldEnv", "GivenFit"]


class WorldEnv:
    """One world's environment at a time, as its controller and probes read it: ``B_eci`` (3,) [T]
    and ``r_ref_eci`` (3,) [m] (rows of the batch's samples, the single run's values)."""

    def __init__(self, B_eci: np.ndarray, r_ref_eci: np.ndarray) -> None:
        self.B_eci, self.r_ref_eci = B_eci, r_ref_eci


class GivenFit:
    """A world controller's best fit, computed by the batch: calling it returns the rotation the
    batch set (``value``), for the positions the controller passes (the batch computed it from
    the same ones). ``fit`` is the controller's own :class:`BestFitRotation`."""

    def __init__(self, fit: BestFitRotation) -> None:
        self.fit = fit
        self.value: tuple[np.ndarray, None] | None = None

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, None]:
        if self.value is None:  # pragma: no cover - the batch sets it before every sample
            raise RuntimeError("the batch's best fit was not set before the controller's sample")
        value, self.value = self.value, None
        return value


def _fit_key(fit: BestFitRotation) -> bytes:
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (fit._pcT, fit._pc_sum, fit._w, fit.p_bar))


def batched_rotation(fit: BestFitRotation, q: np.ndarray) -> np.ndarray:
    """(M, 3, 3) best-fit rotations of the (M, n, 3) positions ``q`` [m] against ``fit``'s reference,
    each equal to ``fit(q[k])[0]`` bit for bit (module docstring)."""
    q_bar = np.matmul(fit._w, q)
    H = np.matmul(fit._pcT, q) - fit._pc_sum[None, :, None] * q_bar[:, None, :]
    U, _, Vt = np.linalg.svd(H)
    Ut = U.swapaxes(-1, -2)
    R = np.matmul(Vt.swapaxes(-1, -2), Ut)
    flip = np.flatnonzero(np.linalg.det(R) < 0.0)
    if flip.size:
        Vt[flip, 2] *= -1.0
        R[flip] = np.matmul(Vt[flip].swapaxes(-1, -2), Ut[flip])
    return R


class RodControlWorlds:
    """The rod controllers of N worlds (module docstring).

    Args:
      controllers: each world's controller (built as its single run builds it); their ``fit`` is
        replaced by a :class:`GivenFit` slot.
      timestep_s: δt [s].
    """

    def __init__(self, controllers: list[RodAttitudeController], *, timestep_s: float) -> None:
        periods = {c.period_s for c in controllers}
        if len(periods) != 1:
            raise ValueError(f"controllers: the worlds' control periods differ {sorted(periods)}")
        self.ctls = controllers
        self.n = len(controllers)
        self.period_s = periods.pop()
        self.dt = float(timestep_s)
        groups: dict[bytes, list[int]] = {}
        for k, c in enumerate(controllers):
            if not isinstance(c.fit, GivenFit):
                c.fit = GivenFit(c.fit)
            groups.setdefault(_fit_key(c.fit.fit), []).append(k)
        self.groups = [np.array(ks, dtype=np.intp) for ks in groups.values()]
        self._initial = [self._controller_state(c) for c in controllers]
        self.reset()

    def reset(self) -> None:
        """The state of the build: no sample yet, nothing held."""
        for c, s in zip(self.ctls, self._initial):
            self._set_controller_state(c, s)
        self.n_ctrl = 0
        self.cmd: list[RodCommand | None] = [None] * self.n

    def due(self, step: int) -> bool:
        """Whether a sample is due at step ``step`` (the single run's test)."""
        return step * self.dt >= self.n_ctrl * self.period_s - 1e-6 * self.dt

    def sample(self, step: int, pos: np.ndarray, env: list[WorldEnv], live: np.ndarray) -> None:
        """The sample at step ``step`` of every live world: ``pos`` (N, nbody, 3) body positions [m],
        ``env`` each world's environment at t; the new commands are held in :attr:`cmd`."""
        t = step * self.dt
        for rows in self.groups:
            rows = rows[live[rows]]
            if not rows.size:
                continue
            c0 = self.ctls[int(rows[0])]
            R = batched_rotation(c0.fit.fit, pos[rows][:, c0._sel])
            for j, k in enumerate(rows.tolist()):
                c = self.ctls[k]
                c.fit.value = (R[j], None)
                state = StepState(t=t, pos=pos[k], vel=None, xquat=None, omega=None, env=env[k], ctrl=self.cmd[k])
                self.cmd[k] = c.update(state)
        self.n_ctrl = int(np.floor(t / self.period_s + 1e-6 * self.dt / self.period_s)) + 1

    # ------------------------------------------------------------------ state
    @staticmethod
    def _controller_state(c: RodAttitudeController) -> dict[str, Any]:
        return {
            "R_prev": None if c._R_prev is None else c._R_prev.copy(),
            "t_prev": float(c._t_prev),
            "stats": c.stats.copy(),
        }

    @staticmethod
    def _set_controller_state(c: RodAttitudeController, s: dict[str, Any]) -> None:
        c._R_prev = None if s["R_prev"] is None else np.array(s["R_prev"], dtype=float, copy=True)
        c._t_prev = float(s["t_prev"])
        c.stats = np.array(s["stats"], dtype=np.int64, copy=True)

    def get_state(self) -> dict[str, Any]:
        """The controllers' state as plain data: the sample index, each world's previous rotation,
        sample time and counters, and its held command (a dict of the command's fields, or ``None``)."""
        return {
            "n_ctrl": self.n_ctrl,
            "controllers": [self._controller_state(c) for c in self.ctls],
            "commands": [None if cmd is None else _command_data(cmd) for cmd in self.cmd],
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        self.n_ctrl = int(state["n_ctrl"])
        for c, s in zip(self.ctls, state["controllers"]):
            self._set_controller_state(c, s)
        self.cmd = [None if d is None else RodCommand(**_command_data(d)) for d in state["commands"]]


def _command_data(cmd: RodCommand | dict[str, Any]) -> dict[str, Any]:
    """The fields of a held command as plain data (arrays copied)."""
    fields = dataclasses.asdict(cmd) if isinstance(cmd, RodCommand) else dict(cmd)
    return {key: _copy(value) for key, value in fields.items()}


def _copy(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    return value
