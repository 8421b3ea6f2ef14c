r"""Shared machinery of the rod-array attitude controllers of the flexible truss.

One control sample (every ``period_s``, zero-order hold in between; default every 0.1 s
integration step) does this loop:

1. **best-fit attitude** ``R`` (body → world = ECI axes) of all particles against their
   undeformed body coordinates ``p_i`` (Kabsch, :class:`~magsail_mj.estimation.attitude.BestFitRotation`);
2. **body rate** by the backward difference of consecutive control samples,
   ``ω_k = vee(log(R_{k−1}ᵀ R_k)) / (t_k − t_{k−1})`` (``rate_method="log"``, default; exact for a
   constant rate) or the first-order ``vee(skew(R_{k−1}ᵀ R_k)) / δt``; at the first sample the known
   initial rate ``ω₀`` is used;
3. **field in body components** ``B_b = Rᵀ B_eci`` (the true field at the reference point);
4. **reference torque** ``T_ref`` (body components, N m) from the subclass's law
   (:mod:`~magsail_mj.control.bdot_flexible`, :mod:`~magsail_mj.control.quaternion_feedback`);
5. **allocation** ``(N1, N2)`` and the Lloyd rod selection by a
   :class:`~magsail_mj.control.allocation.TorqueDistributor`, giving the rod polarities that the
   :class:`~magsail_mj.loads.magnetorquer_rods.MagnetorquerRodLoad` reads from ``state.ctrl``.

The controller's whole state (previous rotation and time, counters, the distributor with its
Lloyd cache) is plain Python/NumPy and pickles, so the runner's checkpoints hold it and a resumed
run continues identically.
"""

from __future__ import annotations

import abc

import math
from dataclasses import dataclass, field
from typing import Any, Literal, Required, Sequence, TypedDict, Unpack

import numpy as np

from magsail_mj.control.allocation import Allocation, TorqueDistributor
from magsail_mj.control.profiles import torque_profile
from magsail_mj.estimation.attitude import BestFitRotation, body_rate_step
from magsail_mj.checkpoint import restorable

__all__ = ["RodCommand", "RodAttitudeController", "ProfileRodController", "step_rate"]


@restorable
@dataclass
class RodCommand:
    """The zero-order-held output of one control sample.

    Attributes:
      t: sample time [s].
      polarity: (n_rods,) int8 rod polarities in {−1, 0, +1} (read by the rod load), or ``None``
        for an ideal-torque controller (no distributor; tests only).
      torque_ref_body: (3,) reference torque ``T_ref`` [N m], body components.
      torque_alloc_body: (3,) torque the allocation promises, ``N1 τ1 + N2 τ2`` [N m], body
        components (``T_ref`` itself when there is no distributor).
      N1, N2: signed numbers of activated rods per family.
      clipped1, clipped2: family saturated (the rounded demand exceeded ``N_max``).
      R: (3, 3) best-fit rotation, body → world.
      omega_body: (3,) estimated body rate [rad/s], body components.
      B_body: (3,) field [T], body components.
      com_world: (3,) centre of mass of the particles in the world frame [m].
      extra: law-specific values (e.g. ``q_err`` (4,), ``gg_comp_body`` (3,)).
      counts: (4,) cumulative numbers of control samples so far, of samples with family 1,
        family 2, either family saturated (a copy, so it survives in the held command).
    """

    t: float
    polarity: np.ndarray | None
    torque_ref_body: np.ndarray
    torque_alloc_body: np.ndarray
    N1: int
    N2: int
    clipped1: bool
    clipped2: bool
    R: np.ndarray
    omega_body: np.ndarray
    B_body: np.ndarray
    com_world: np.ndarray
    extra: dict[str, Any] = field(default_factory=dict)
    counts: np.ndarray = field(default_factory=lambda: np.zeros(4, dtype=np.int64))


def step_rate(R_prev: np.ndarray, R: np.ndarray, dt: float, method: str) -> np.ndarray:
    """Backward-difference body rate of one step, as
    :func:`~magsail_mj.estimation.attitude.body_rate_step` but with a scalar fast path.

    ``M = R_prevᵀ R``, ``s = vee(M)`` (= sin θ â); ``log``: ``ω = θ/sin θ · s / δt`` with
    ``θ = atan2(|s|, (tr M − 1)/2)`` and the series ``1 + θ²/6 + 7θ⁴/360`` below 1e-4; steps with
    ``cos θ < −1/2`` go to the general :func:`~magsail_mj.estimation.attitude.so3_log`.
    ``first_order``: ``ω = s / δt``.
    """
    M = R_prev.T @ R
    s = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    if method == "first_order":
        return s / dt
    c = 0.5 * (M[0, 0] + M[1, 1] + M[2, 2] - 1.0)
    if c < -0.5:
        return body_rate_step(R_prev, R, dt, method="log")
    sn = math.sqrt(float(s @ s))
    th = math.atan2(sn, c)
    f = 1.0 + th * th / 6.0 + 7.0 * th**4 / 360.0 if th < 1e-4 else th / sn
    return s * (f / dt)


def _vec3(value: Sequence[float], name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}")
    return a


class RodControllerOptions(TypedDict, total=False):
    """The arguments of :class:`RodAttitudeController` that its subclasses take as ``**base`` and
    pass on (see there); the first four are required."""

    reference_nodes: Required[np.ndarray]
    masses: Required[np.ndarray | float]
    distributor: Required[TorqueDistributor | None]
    period_s: Required[float]
    node_bodies: np.ndarray | None
    omega0_body: Sequence[float]
    rate_method: Literal["log", "first_order"]


class RodAttitudeController(abc.ABC):
    """Base class: estimation + reference torque (subclass) + allocation.

    Args:
      reference_nodes: (n, 3) undeformed body coordinates ``p_i`` of the particles [m].
      masses: (n,) particle masses [kg] (for the centre of mass ``x_c``).
      node_bodies: (n,) MuJoCo body index of each particle (``state.pos`` rows); default
        ``1 … n`` (node ``i`` is body ``i + 1``).
      distributor: the rod allocation; ``None`` gives an ideal-torque controller whose
        command carries ``T_ref`` and no polarities (used by the rigid-body tests).
      period_s: control period [s] (> 0); the runner holds the command in between.
      omega0_body: (3,) rate used at the first sample [rad/s], body components.
      rate_method: ``"log"`` (default) or ``"first_order"`` backward difference.

    Subclasses implement :meth:`reference_torque`.
    """

    def __init__(
        self,
        *,
        reference_nodes: np.ndarray,
        masses: np.ndarray | float,
        node_bodies: np.ndarray | None = None,
        distributor: TorqueDistributor | None,
        period_s: float,
        omega0_body: Sequence[float] = (0.0, 0.0, 0.0),
        rate_method: Literal["log", "first_order"] = "log",
    ) -> None:
        p = np.asarray(reference_nodes, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 3:
            raise ValueError(f"reference_nodes: expected an (n >= 3, 3) array [m], got shape {p.shape}")
        n = p.shape[0]
        m = np.asarray(masses, dtype=float)
        m = np.full(n, float(m)) if m.ndim == 0 else m
        if m.shape != (n,) or np.any(~(m >= 0)) or not m.sum() > 0:
            raise ValueError(f"masses: expected {n} masses >= 0 [kg] with a positive sum, got shape {m.shape}")
        if node_bodies is None:
            node_bodies = np.arange(1, n + 1)
        nb = np.asarray(node_bodies, dtype=np.int64)
        if nb.shape != (n,) or np.any(nb < 0):
            raise ValueError(f"node_bodies: expected {n} body indices >= 0, got shape {nb.shape}")
        if not (np.isfinite(period_s) and period_s > 0):
            raise ValueError(f"period_s: must be > 0 s, got {period_s!r}")
        if rate_method not in ("log", "first_order"):
            raise ValueError(f"rate_method: must be 'log' or 'first_order', got {rate_method!r}")
        self.fit = BestFitRotation(p)
        self.masses = m
        self._w_com = m / m.sum()
        self.node_bodies = nb
        self._sel: slice | np.ndarray = slice(int(nb[0]), int(nb[-1]) + 1) if np.all(np.diff(nb) == 1) else nb
        self.distributor = distributor
        self.period_s = float(period_s)
        self.omega0_body = _vec3(omega0_body, "omega0_body")
        self.rate_method = rate_method
        self._R_prev: np.ndarray | None = None
        self._t_prev = 0.0
        # cumulative counters over all control samples: samples, family 1 / 2 / either saturated
        self.stats = np.zeros(4, dtype=np.int64)

    # ------------------------------------------------------------------ law
    @abc.abstractmethod
    def reference_torque(
        self, *, t: float, R: np.ndarray, omega_body: np.ndarray, B_body: np.ndarray, com_world: np.ndarray, env: Any
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """``(T_ref_body [N m], extra)`` of the control law; each subclass defines it."""

    # ------------------------------------------------------------------ one sample
    def estimate(self, state: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Best-fit rotation ``R``, body rate ``ω`` [rad/s] and centre of mass ``x_c`` [m] at ``state``.

        Updates the stored previous rotation (call once per sample).
        """
        pos = state.pos[self._sel]
        R, _ = self.fit(pos)
        if self._R_prev is None:
            omega = self.omega0_body.copy()
        else:
            dt = float(state.t) - self._t_prev
            omega = step_rate(self._R_prev, R, dt, self.rate_method) if dt > 0 else np.zeros(3)
        self._R_prev = R
        self._t_prev = float(state.t)
        return R, omega, self._w_com @ pos

    def update(self, state: Any) -> RodCommand:
        """One control sample (module docstring): state → :class:`RodCommand`."""
        env = state.env
        if env is None:
            raise ValueError("state.env: the rod controllers need an environment sample (B_eci, r_ref_eci)")
        R, omega, xc = self.estimate(state)
        B_body = R.T @ np.asarray(env.B_eci, dtype=float)
        T_ref, extra = self.reference_torque(
            t=float(state.t), R=R, omega_body=omega, B_body=B_body, com_world=xc, env=env
        )
        if self.distributor is None:
            polarity, al = None, None
            T_alloc = np.asarray(T_ref, dtype=float).copy()
        else:
            polarity, al = self.distributor(T_ref, B_body)
            T_alloc = al.torque_body
        self._count(al)
        return RodCommand(
            t=float(state.t),
            polarity=polarity,
            torque_ref_body=np.asarray(T_ref, dtype=float),
            torque_alloc_body=T_alloc,
            N1=al.N1 if al else 0,
            N2=al.N2 if al else 0,
            clipped1=bool(al.clipped1) if al else False,
            clipped2=bool(al.clipped2) if al else False,
            R=R,
            omega_body=omega,
            B_body=B_body,
            com_world=xc,
            extra=extra,
            counts=self.stats.copy(),
        )

    def _count(self, al: Allocation | None) -> None:
        self.stats[0] += 1
        if al is not None:
            self.stats[1] += al.clipped1
            self.stats[2] += al.clipped2
            self.stats[3] += al.clipped1 or al.clipped2


class ProfileRodController(RodAttitudeController):
    """Open-loop rod drive (``control.kind = "open_loop"``): ``T_ref`` is the Robb et al. 2022a Table 1 / Eq. 9 torque
    profile about one body axis, ``T_ref = τ(t) ê_axis`` [N m], fed through the same allocation.

    Args:
      kind, tau_max_Nm, t_end_s, t_v_s: the profile (see :func:`magsail_mj.control.profiles.torque_profile`).
      axis: body axis index 0, 1, 2 (x1, y1, z1).
      Other arguments: see :class:`RodAttitudeController`.
    """

    law = "open_loop"

    def __init__(
        self,
        *,
        kind: str,
        tau_max_Nm: float,
        t_end_s: float,
        t_v_s: float | None = None,
        axis: int = 0,
        **base: Unpack[RodControllerOptions],
    ) -> None:
        super().__init__(**base)
        if axis not in (0, 1, 2):
            raise ValueError(f"axis: must be 0, 1 or 2, got {axis!r}")
        self.profile = {"kind": kind, "tau_max": float(tau_max_Nm), "t_end": float(t_end_s), "t_v": t_v_s}
        self.axis = int(axis)

    def reference_torque(
        self, *, t: float, R: np.ndarray, omega_body: np.ndarray, B_body: np.ndarray, com_world: np.ndarray, env: Any
    ) -> tuple[np.ndarray, dict[str, Any]]:
        T = np.zeros(3)
        T[self.axis] = float(
            torque_profile(
                self.profile["kind"],
                t,
                tau_max=self.profile["tau_max"],
                t_end=self.profile["t_end"],
                t_v=self.profile["t_v"],
            )
        )
        return T, {}
