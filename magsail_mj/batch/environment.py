r"""The environments of a batch's worlds, sampled for every world at once.

Each world rides the reference orbit of its own config (its epoch, orbit, field, Sun and
atmosphere tables). :class:`EnvironmentStack` holds the *distinct* environments of a batch (worlds
whose environment tables and duration are equal share one, built once at load) and samples them
together: the coefficient tables of the :class:`~magsail_mj.environment.environment.Environment`\ s
(piecewise cubics on one time grid) are stacked into an ``(E, K, 4, nch)`` array, and a sample at
``t`` is one interval lookup (the same for every environment: they share the grid) and one
``(2, 4) @ (4, nch)`` product per environment through :func:`numpy.matmul` — the product
:meth:`Environment.sample` forms, so each world's values equal its single run's bit for bit. The
derived quantities (Sun direction and distance, cylindrical shadow, solar pressure, exponential
density, flow velocity) are then formed element-wise over the environments with the single run's
formulas and order of operations, and gathered to the worlds.

:class:`EnvSamples` computes each quantity on first access: a step uses the field at most samples
and the orbit state at the attitude samples; the rest only at record steps and in the loads that
need it.

Frames: every vector in ECI components = world axes, as :class:`EnvSample`.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from magsail_mj.batch.worldmath import per_world, pow_per_world
from magsail_mj.environment.atmosphere import EXPONENTIAL_TABLE
from magsail_mj.environment.constants import AU
from magsail_mj.environment.environment import Environment

__all__ = ["EnvironmentStack", "EnvSamples"]

_H0_KM = EXPONENTIAL_TABLE[:, 0].copy()
_ROWS = np.array([(float(h0) * 1e3, float(r0), float(H) * 1e3) for h0, r0, H in EXPONENTIAL_TABLE])


class EnvironmentStack:
    """The distinct environments of a batch and which world rides which.

    Args:
      environments: the distinct environments (E ≥ 1), all on one time grid (same step, start and
        length) and with the same channels.
      world_env: (N,) index into ``environments`` of each world.

    Raises:
      ValueError: the environments' grids or channels differ (naming what differs).
    """

    def __init__(self, environments: list[Environment], world_env: np.ndarray) -> None:
        tables = [e._table for e in environments]
        first = tables[0]
        for k, tb in enumerate(tables[1:], start=1):
            if (tb.t0, tb.h, tb.K, tb.nch) != (first.t0, first.h, first.K, first.nch):
                raise ValueError(
                    f"environments: environment {k} has grid (t0, h, K, channels) = {(tb.t0, tb.h, tb.K, tb.nch)}, "
                    f"environment 0 {(first.t0, first.h, first.K, first.nch)}"
                )
        self.environments = list(environments)
        self.world_env = np.asarray(world_env, dtype=np.intp)
        self.t0, self.h, self.K = first.t0, first.h, first.K
        self.t_max = min(e.t_max for e in environments)
        self.coef = np.stack([tb.coef for tb in tables])  # (E, K, 4, nch)
        self.R_E = np.array([e.R_E for e in environments])
        self.has_sun = np.array([e._has_sun for e in environments])
        self.shadow = np.array([e._shadow for e in environments])
        self.P0 = np.array([float(e._P) for e in environments])
        self.scale_distance = np.array([bool(e._scale_distance) for e in environments])
        self.exponential = np.array([e._atmo == "exponential" for e in environments])
        self.msis = np.array([bool(e._msis) for e in environments])
        self.corotating = np.array([bool(e._corot) for e in environments])
        self.omega_earth = np.array([float(e.omega_earth) for e in environments])

    def sample(self, t: float) -> "EnvSamples":
        """Every world's environment at time ``t`` [s] (:meth:`Environment.sample` per world).

        Raises ValueError naming ``t`` when it lies outside [0, t_max]."""
        if not (-1e-9 <= t <= self.t_max + 1e-9):
            raise ValueError(
                f"t: {t!r} s is outside the precomputed span [0, {self.t_max}] s "
                "(build the Environment with a longer duration_s)"
            )
        s = (t - self.t0) / self.h
        i = int(s)
        if i >= self.K:
            i = self.K - 1
        elif i < 0:
            i = 0
        return EnvSamples(self, t, i, t - (self.t0 + i * self.h))


class EnvSamples:
    """The environment of every world at one time: (N, …) arrays, each formed on first access
    (values of :class:`~magsail_mj.environment.environment.EnvSample`, same names)."""

    def __init__(self, stack: EnvironmentStack, t: float, interval: int, tau: float) -> None:
        self.stack, self.t = stack, float(t)
        self._i, self._tau = interval, tau
        self._w = stack.world_env

    @cached_property
    def _val(self) -> np.ndarray:
        """(E, nch) every environment's channels at t: row 0 of ``P @ coef[i]`` with
        ``P = ((1, τ, τ², τ³), (0, 1, 2τ, 3τ²))``, the product :meth:`Environment.sample` forms."""
        tau = self._tau
        t2 = tau * tau
        P = np.array(((1.0, tau, t2, t2 * tau), (0.0, 1.0, 2.0 * tau, 3.0 * t2)))
        return np.matmul(P, self.stack.coef[:, self._i])[:, 0]

    def _worlds(self, per_env: np.ndarray) -> np.ndarray:
        return per_env[self._w]

    @cached_property
    def r_ref_eci(self) -> np.ndarray:
        """(N, 3) reference-orbit position [m]."""
        return self._worlds(self._val[:, 0:3])

    @cached_property
    def v_ref_eci(self) -> np.ndarray:
        """(N, 3) reference-orbit velocity [m/s]."""
        return self._worlds(self._val[:, 3:6])

    @cached_property
    def B_eci(self) -> np.ndarray:
        """(N, 3) magnetic field at the reference position [T]."""
        return self._worlds(self._val[:, 6:9])

    @cached_property
    def B_dot_eci(self) -> np.ndarray:
        """(N, 3) time derivative of the field along the reference orbit [T/s]: row 1 of
        ``P @ coef[i]`` (:attr:`_val`), as :meth:`Environment.sample` forms ``B_dot_eci``."""
        tau = self._tau
        t2 = tau * tau
        P = np.array(((1.0, tau, t2, t2 * tau), (0.0, 1.0, 2.0 * tau, 3.0 * t2)))
        return self._worlds(np.matmul(P, self.stack.coef[:, self._i])[:, 1, 6:9])

    @cached_property
    def _rn(self) -> np.ndarray:
        v = self._val
        rx, ry, rz = v[:, 0], v[:, 1], v[:, 2]
        return np.sqrt(rx * rx + ry * ry + rz * rz)

    @cached_property
    def _sun(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per environment: unit vector to the Sun (E, 3), distance [m] (E,), solar pressure [N/m²] (E,)."""
        st, v = self.stack, self._val
        rx, ry, rz = v[:, 0], v[:, 1], v[:, 2]
        Sx, Sy, Sz = v[:, 9], v[:, 10], v[:, 11]
        with np.errstate(divide="ignore", invalid="ignore"):
            dx, dy, dz = Sx - rx, Sy - ry, Sz - rz
            dist = np.sqrt(dx * dx + dy * dy + dz * dz)
            sun = np.stack((dx / dist, dy / dist, dz / dist), axis=1)
            sn = np.sqrt(Sx * Sx + Sy * Sy + Sz * Sz)
            proj = (rx * Sx + ry * Sy + rz * Sz) / sn
            rn = self._rn
            in_shadow = st.shadow & (proj < 0.0) & ((rn * rn - proj * proj) < st.R_E * st.R_E)
            scaled = st.P0 * pow_per_world(AU / dist, 2)
        P = np.where(in_shadow, 0.0, np.where(st.scale_distance, scaled, st.P0))
        sun = np.where(st.has_sun[:, None], sun, 0.0)
        dist = np.where(st.has_sun, dist, math.inf)
        return sun, dist, np.where(st.has_sun, P, 0.0)

    @cached_property
    def sun_eci(self) -> np.ndarray:
        """(N, 3) unit vector from the reference position to the Sun (zeros without a Sun)."""
        return self._worlds(self._sun[0])

    @cached_property
    def srp_pressure_N_m2(self) -> np.ndarray:
        """(N,) solar pressure on an absorber [N/m²] (0 in shadow or without a Sun)."""
        return self._worlds(self._sun[2])

    @cached_property
    def density_kg_m3(self) -> np.ndarray:
        """(N,) atmospheric density [kg/m³]: the exponential model's ``ρ₀ exp(−(h − h₀)/H)`` of the
        band holding the altitude h = |r| − R_E, MSIS from its table, else 0."""
        st, rn = self.stack, self._rn
        alt = rn - st.R_E
        k = np.clip(np.searchsorted(_H0_KM, alt * 1e-3, side="right") - 1, 0, len(_ROWS) - 1)
        h0, r0, H = _ROWS[k, 0], _ROWS[k, 1], _ROWS[k, 2]
        expo = np.where(rn > 0, r0 * per_world(math.exp, -(alt - h0) / H), 0.0)
        rho = np.where(st.exponential, expo, 0.0)
        if st.msis.any():
            rho = np.where(st.msis, per_world(math.exp, self._val[:, 12]), rho)
        return self._worlds(rho)

    @cached_property
    def v_rel_eci(self) -> np.ndarray:
        """(N, 3) velocity of the reference orbit relative to the atmosphere [m/s] (v − ω⊕ × r when
        the atmosphere co-rotates)."""
        st, v = self.stack, self._val
        w = st.omega_earth
        corot = np.stack((v[:, 3] + w * v[:, 1], v[:, 4] - w * v[:, 0], v[:, 5]), axis=1)
        return self._worlds(np.where(st.corotating[:, None], corot, v[:, 3:6]))
