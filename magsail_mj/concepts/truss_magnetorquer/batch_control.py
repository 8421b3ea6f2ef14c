r"""The truss's rod-array controller over a world axis.

A control sample of the single run (:class:`~magsail_mj.control.rod_attitude.RodAttitudeController`,
Robb et al. 2022a, Eqs. 11–13) is, per world:

1. the best-fit rotation ``R`` of the particles (Kabsch: ``q̄ = w·q``, ``H = p_cᵀ q − (Σ p_c) q̄ᵀ``,
   ``H = U Σ Vᵀ``, ``R = V Uᵀ`` with the third row of Vᵀ negated where ``det R < 0``) and the
   centre of mass ``x_c = w_m·q``;
2. the body rate: the initial rate ``ω₀`` at the first sample, then the backward difference
   (:func:`~magsail_mj.control.rod_attitude.step_rate`: ``M = R_prevᵀ R``, ``s = vee(M)``,
   ``θ = atan2(|s|, (tr M − 1)/2)``, ``ω = s θ/|s| / δt`` with the series
   ``1 + θ²/6 + 7θ⁴/360`` below θ = 10⁻⁴, or ``s/δt`` for ``rate_method = "first_order"``);
3. ``B_b = Rᵀ B``; the reference torque of the law (B-dot: ``T = k (ω × B_b) × B_b``; the
   quaternion feedback and the open-loop profile: each world's own controller's
   ``reference_torque``, per world);
4. the allocation (Eqs. 11–13, ``mode`` paper or exact:
   :func:`~magsail_mj.control.allocation._allocate_core`: the rounded and clipped rod counts
   ``N1``, ``N2``, the delivered ``N1 τ1 + N2 τ2``) and the Lloyd rod selection of each world's
   counts (its own :class:`~magsail_mj.control.lloyd.LloydSelector`, per world, looked up again
   only when the world's counts changed: a selection is a function of the counts);
5. the counters (samples, family 1, family 2, either saturated).

:class:`RodControlWorlds` does every step but the selection lookup and the non-B-dot laws for all
live worlds at once, in the single run's order of operations: the BLAS products (``w·q``,
``p_cᵀ q``, ``R_prevᵀ R``, ``Rᵀ B``, ``s·s``) as one :func:`numpy.matmul` per world on the single
run's shapes, the LAPACK ``svd`` and ``det`` batched, ``atan2`` and ``θ⁴`` through :mod:`math`
per world (:mod:`magsail_mj.batch.worldmath`), the rest element-wise — so each world's commands
equal its single run's bit for bit. A world whose rotation turned by more than 120° between two
samples takes :func:`~magsail_mj.control.rod_attitude.step_rate` itself (its general SO(3) log).
The held command of each world (:class:`~magsail_mj.control.rod_attitude.RodCommand`) is formed
from the batch's arrays when the probes read it (:meth:`command`).

Worlds whose reference particle sets or mass weights differ (another ``lattice.side_m`` or
``mass``) are fitted in separate passes. The schedule (``control.period_s``, ``sim.timestep_s``)
is the same in every world, so the sample index ``n_ctrl`` is one number: sample ``k`` is due at
step ``s`` when ``s·δt ≥ k·period − 10⁻⁶ δt``, as :class:`magsail_mj.sim.Simulation` decides it.
The worlds' controller objects give their parameters; the batch holds their state.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from magsail_mj.batch.worldmath import cross, dot_blas, mat_t_vec_blas, pow_per_world
from magsail_mj.control.allocation import SINGULAR_GRAM_REL, TINY_TORQUE_REL
from magsail_mj.control.bdot_flexible import BdotRodController
from magsail_mj.control.rod_attitude import RodAttitudeController, RodCommand, step_rate
from magsail_mj.estimation.attitude import BestFitRotation

__all__ = ["RodControlWorlds", "WorldEnv", "batched_rotation", "step_rates"]

_STATE = ("R_prev", "has_prev", "t_prev", "stats", "polarity", "T_ref", "T_alloc", "N", "clipped", "R", "omega")
_STATE += ("B_body", "com", "counts", "has_cmd", "t_cmd")


class WorldEnv:
    """One world's environment at a time, as its controller and probes read it: ``B_eci`` (3,) [T]
    and ``r_ref_eci`` (3,) [m] (rows of the batch's samples, the single run's values)."""

    def __init__(self, B_eci: np.ndarray, r_ref_eci: np.ndarray) -> None:
        self.B_eci, self.r_ref_eci = B_eci, r_ref_eci


def _key(*arrays: np.ndarray) -> bytes:
    return b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)


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


def step_rates(R_prev: np.ndarray, R: np.ndarray, dt: np.ndarray, methods: list[str]) -> np.ndarray:
    """(M, 3) body rates [rad/s] of :func:`~magsail_mj.control.rod_attitude.step_rate` for (M, 3, 3)
    rotations ``R_prev`` → ``R`` over ``dt`` (M,) [s] > 0, each world's ``method``, bit for bit."""
    M = np.matmul(R_prev.swapaxes(-1, -2), R)
    s = 0.5 * np.stack((M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]), axis=1)
    c = 0.5 * (M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2] - 1.0)
    sn = np.sqrt(dot_blas(s, s))
    th = np.array([math.atan2(a, b) for a, b in zip(sn.tolist(), c.tolist())])
    series = 1.0 + th * th / 6.0 + 7.0 * pow_per_world(th, 4) / 360.0
    f = np.where(th < 1e-4, series, th / sn)
    out = s * (f / dt)[:, None]
    first = np.array([m == "first_order" for m in methods])
    if first.any():
        out[first] = s[first] / dt[first][:, None]
    for j in np.flatnonzero(~first & (c < -0.5)).tolist():
        out[j] = step_rate(R_prev[j], R[j], float(dt[j]), methods[j])
    return out


def _round_clip(x: np.ndarray, n_max: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(r, N)`` of :func:`~magsail_mj.control.allocation._rnd_clip` per entry (finite or ±inf
    ``x``): ``r = sign(x) ⌊|x| + ½⌋`` (beyond ``n_max + 1``: ``±(n_max + 1)``), ``N`` clipped to
    ``±n_max``; int64."""
    ax = np.abs(x)
    f = np.floor(np.where(np.isfinite(ax), ax, 0.0))
    r = np.where(ax - f >= 0.5, f + 1.0, f)
    r = np.where(x >= 0, r, -r)
    big = ~(ax < n_max + 1)
    r = np.where(big, np.where(x > 0, n_max + 1, -(n_max + 1)), r).astype(np.int64)
    return r, np.clip(r, -n_max, n_max)


class RodControlWorlds:
    """The rod controllers of N worlds (module docstring).

    Args:
      controllers: each world's controller (built as its single run builds it: its law, gains,
        rate method, initial rate, weights and distributor); the worlds' laws are of one kind.
      timestep_s: δt [s].

    Raises:
      ValueError: the worlds' control periods or laws differ, or a controller has no distributor.
    """

    def __init__(self, controllers: list[RodAttitudeController], *, timestep_s: float) -> None:
        periods = {c.period_s for c in controllers}
        if len(periods) != 1:
            raise ValueError(f"controllers: the worlds' control periods differ {sorted(periods)}")
        if len({type(c) for c in controllers}) != 1:
            raise ValueError("controllers: the worlds' control laws differ")
        if any(c.distributor is None for c in controllers):
            raise ValueError("controllers: every world's controller needs its rod distributor")
        self.ctls = controllers
        self.n = len(controllers)
        self.period_s = periods.pop()
        self.dt = float(timestep_s)
        self.bdot = isinstance(controllers[0], BdotRodController)
        self.k_bdot = np.array([getattr(c, "k", 0.0) for c in controllers])
        self.omega0 = np.array([c.omega0_body for c in controllers])
        self.methods = [c.rate_method for c in controllers]
        self.exact = np.array([c.distributor.mode == "exact" for c in controllers])
        self.m_rod = np.array([c.distributor.m_rod_Am2 for c in controllers], dtype=float)  # (N, 2) [A m²]
        self.n_max = np.array([c.distributor.n_max for c in controllers], dtype=np.int64)  # (N, 2)
        self.n_rods = int(controllers[0].distributor.selector.n_rods)
        fits: dict[bytes, list[int]] = {}
        weights: dict[bytes, list[int]] = {}
        for k, c in enumerate(controllers):
            fits.setdefault(_key(c.fit._pcT, c.fit._pc_sum, c.fit._w, c.fit.p_bar), []).append(k)
            weights.setdefault(_key(c._w_com), []).append(k)
        self.fit_groups = [np.array(ks, dtype=np.intp) for ks in fits.values()]
        self.weight_groups = [np.array(ks, dtype=np.intp) for ks in weights.values()]
        sels = {(c._sel.start, c._sel.stop) if isinstance(c._sel, slice) else None for c in controllers}
        if len(sels) != 1 or None in sels:
            raise ValueError("controllers: the worlds' particles must be one block of bodies")
        self.sel = controllers[0]._sel
        self.reset()

    def reset(self) -> None:
        """The state of the build: no sample yet, nothing held."""
        n, r = self.n, self.n_rods
        self.n_ctrl = 0
        self.R_prev = np.zeros((n, 3, 3))
        self.has_prev = np.zeros(n, dtype=bool)
        self.t_prev = np.zeros(n)
        self.stats = np.zeros((n, 4), dtype=np.int64)
        self.polarity = np.zeros((n, r), dtype=np.int8)
        self.T_ref = np.zeros((n, 3))
        self.T_alloc = np.zeros((n, 3))
        self.N = np.zeros((n, 2), dtype=np.int64)
        self.clipped = np.zeros((n, 2), dtype=bool)
        self.R = np.zeros((n, 3, 3))
        self.omega = np.zeros((n, 3))
        self.B_body = np.zeros((n, 3))
        self.com = np.zeros((n, 3))
        self.counts = np.zeros((n, 4), dtype=np.int64)
        self.has_cmd = np.zeros(n, dtype=bool)
        self.t_cmd = np.zeros(n)
        self.extra: list[dict[str, Any]] = [{} for _ in range(n)]

    def due(self, step: int) -> bool:
        """Whether a sample is due at step ``step`` (the single run's test)."""
        return step * self.dt >= self.n_ctrl * self.period_s - 1e-6 * self.dt

    def command(self, k: int) -> RodCommand | None:
        """World ``k``'s held command as its single run holds it (``None`` before its first sample)."""
        if not self.has_cmd[k]:
            return None
        return RodCommand(
            t=float(self.t_cmd[k]),
            polarity=self.polarity[k],
            torque_ref_body=self.T_ref[k],
            torque_alloc_body=self.T_alloc[k],
            N1=int(self.N[k, 0]),
            N2=int(self.N[k, 1]),
            clipped1=bool(self.clipped[k, 0]),
            clipped2=bool(self.clipped[k, 1]),
            R=self.R[k],
            omega_body=self.omega[k],
            B_body=self.B_body[k],
            com_world=self.com[k],
            extra=self.extra[k],
            counts=self.counts[k],
        )

    # ------------------------------------------------------------------ the sample
    def sample(self, step: int, pos: np.ndarray, B: np.ndarray, env: list[WorldEnv], live: np.ndarray) -> None:
        """The sample at step ``step`` of every live world: ``pos`` (N, nbody, 3) body positions [m],
        ``B`` (N, 3) the field [T] and ``env`` each world's environment at t."""
        t = step * self.dt
        rows = np.flatnonzero(live)
        if rows.size:
            R, xc = self._fit(pos, rows)
            omega = self._rates(t, rows, R)
            Bb = mat_t_vec_blas(R.reshape(-1, 9), np.asarray(B[rows], dtype=float))
            T_ref, extra = self._reference(t, rows, R, omega, Bb, xc, env)
            self._allocate(t, rows, T_ref, Bb)
            self.R[rows], self.omega[rows], self.B_body[rows], self.com[rows] = R, omega, Bb, xc
            self.T_ref[rows] = T_ref
            for j, k in enumerate(rows.tolist()):
                self.extra[k] = extra[j]
        self.n_ctrl = int(np.floor(t / self.period_s + 1e-6 * self.dt / self.period_s)) + 1

    def _fit(self, pos: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M, 3, 3) best-fit rotations and (M, 3) centres of mass [m] of the worlds ``rows``."""
        R, xc = np.empty((len(rows), 3, 3)), np.empty((len(rows), 3))
        where = np.full(self.n, -1)
        where[rows] = np.arange(len(rows))
        for group in self.fit_groups:
            g = group[where[group] >= 0]
            if g.size:
                R[where[g]] = batched_rotation(self.ctls[int(g[0])].fit, pos[g][:, self.sel])
        for group in self.weight_groups:
            g = group[where[group] >= 0]
            if g.size:
                xc[where[g]] = np.matmul(self.ctls[int(g[0])]._w_com, pos[g][:, self.sel])
        return R, xc

    def _rates(self, t: float, rows: np.ndarray, R: np.ndarray) -> np.ndarray:
        """(M, 3) body rates [rad/s]: the initial rate at the first sample, else the backward
        difference (zero when no time has passed); the rotations become the previous ones."""
        omega = np.array(self.omega0[rows])
        prev = self.has_prev[rows]
        dt = t - self.t_prev[rows]
        moved = prev & (dt > 0)
        omega[prev & ~moved] = 0.0
        if moved.any():
            j = np.flatnonzero(moved)
            omega[j] = step_rates(self.R_prev[rows[j]], R[j], dt[j], [self.methods[k] for k in rows[j].tolist()])
        self.R_prev[rows] = R
        self.has_prev[rows] = True
        self.t_prev[rows] = t
        return omega

    def _reference(
        self,
        t: float,
        rows: np.ndarray,
        R: np.ndarray,
        omega: np.ndarray,
        Bb: np.ndarray,
        xc: np.ndarray,
        env: list[WorldEnv],
    ) -> tuple[np.ndarray, list[dict[str, Any]]]:
        """(M, 3) reference torques [N m] and each world's extra values: B-dot over the worlds,
        another law by each world's controller."""
        if self.bdot:
            return self.k_bdot[rows][:, None] * cross(cross(omega, Bb), Bb), [{} for _ in rows]
        T, extras = np.empty((len(rows), 3)), []
        for j, k in enumerate(rows.tolist()):
            value, extra = self.ctls[k].reference_torque(
                t=t, R=R[j], omega_body=omega[j], B_body=Bb[j], com_world=xc[j], env=env[k]
            )
            T[j] = np.asarray(value, dtype=float)
            extras.append(extra)
        return T, extras

    def _allocate(self, t: float, rows: np.ndarray, T: np.ndarray, B: np.ndarray) -> None:
        """The allocation (Eqs. 11–13; module docstring), the rod selections and the counters of
        the worlds ``rows``, held as their commands."""
        bad = ~np.isfinite(T).all(axis=1) | ~np.isfinite(B).all(axis=1)
        for j in np.flatnonzero(bad).tolist():  # the single run's ValueError, naming the inputs
            self.ctls[int(rows[j])].distributor(T[j], B[j])
        m1, m2 = self.m_rod[rows, 0], self.m_rod[rows, 1]
        n1, n2 = self.n_max[rows, 0], self.n_max[rows, 1]
        Tx, Ty, Tz = T[:, 0], T[:, 1], T[:, 2]
        Bx, By, Bz = B[:, 0], B[:, 1], B[:, 2]
        a = Bz * Bz + By * By
        b = Bz * Bz + Bx * Bx
        c = -By * Bx
        tiny = TINY_TORQUE_REL * TINY_TORQUE_REL * (Bx * Bx + By * By + Bz * Bz)
        ok1 = (m1 > 0) & (a > tiny)
        ok2 = (m2 > 0) & (b > tiny)
        Tu1 = -Ty * Bz + Tz * By
        Tu2 = Tx * Bz - Tz * Bx
        x1 = np.where(ok1, Tu1 / a / m1, 0.0)
        exact = self.exact[rows]
        if exact.any():
            det = a * b - c * c
            use = exact & ok1 & ok2 & (det >= SINGULAR_GRAM_REL * a * b)
            x1 = np.where(use, (b * Tu1 - c * Tu2) / det / m1, x1)
        r1, N1 = _round_clip(x1, n1)
        x2 = np.where(ok2, (Tu2 - N1 * m1 * c) / b / m2, 0.0)
        r2, N2 = _round_clip(x2, n2)
        zero = np.zeros(len(rows))
        tau1 = np.stack((zero, -m1 * Bz, m1 * By), axis=1)
        tau2 = np.stack((m2 * Bz, zero, -m2 * Bx), axis=1)
        self.T_alloc[rows] = N1[:, None] * tau1 + N2[:, None] * tau2
        clipped = np.stack((np.abs(r1) > n1, np.abs(r2) > n2), axis=1)
        counts = np.stack((N1, N2), axis=1)
        new = ~self.has_cmd[rows] | (counts != self.N[rows]).any(axis=1)
        for k, c1, c2 in zip(rows[new].tolist(), N1[new].tolist(), N2[new].tolist()):
            self.polarity[k] = self.ctls[k].distributor.selector.polarity((c1, c2))
        self.N[rows] = counts
        self.clipped[rows] = clipped
        self.stats[rows] += np.stack(
            (np.ones(len(rows), dtype=np.int64), clipped[:, 0], clipped[:, 1], clipped.any(axis=1)), axis=1
        )
        self.counts[rows] = self.stats[rows]
        self.has_cmd[rows] = True
        self.t_cmd[rows] = t

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """The controllers' state as plain data: the sample index, each world's previous rotation,
        sample time and counters, and its held command (arrays over the worlds, copied)."""
        out: dict[str, Any] = {name: getattr(self, name).copy() for name in _STATE}
        out.update(n_ctrl=self.n_ctrl, extra=[{k: np.array(v) for k, v in e.items()} for e in self.extra])
        return out

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        for name in _STATE:
            setattr(self, name, np.array(state[name], copy=True))
        self.n_ctrl = int(state["n_ctrl"])
        self.extra = [{k: np.array(v) for k, v in e.items()} for e in state["extra"]]
