r"""CNUSAIL-1 actuators: magnetorquers (rods + air coil) and reaction wheels with DC motors.

Source: Yoo et al. 2016, Eqs. 5–11, with the misprints corrected where each equation is stated.

Magnetorquers (Yoo et al. 2016, Eqs. 5–7)
--------------------
Torque on the bus, body components (paper Eq. 5):

    T_mag = M × B_B,

with M the commanded dipole [A m²] and B_B the local field in body axes [T]. The load adds it in
world (= ECI-parallel) axes, R M × B_eci with R = body → world, to ``xfrc_applied[bus, 3:6]``.

Dipole helpers (used to report turns and current for a dipole; the simulation commands dipoles):

* air coil (Eq. 6): M = n i A;
* cored rod (Eq. 7): M = π r² n i [1 + (μ_r − 1)/(1 + (μ_r − 1) N_d)], with the cylinder
  demagnetising factor N_d ≈ 4(ln ℓ − 1)/(ℓ² − 4 ln ℓ), ℓ = L/r.

Limits: ``"command"`` = 0.2, 0.2, 0.1 A m² (default; text and Table 5) or ``"half_watt"`` =
0.02, 0.02, 0.01 A m² (the "0.5 W" figures). B-dot clips each axis (:func:`saturate_per_axis`);
unloading scales the whole vector (:func:`saturate_uniform`). Electrical power per axis (assumed,
reporting only): P_j = P_max (M_j/M_j,max)².

Magnetometer blanking (Yoo et al. 2016, Eqs. 5–7): in each magnetorquer cycle of length T_c (2 s) the coils are on for
the first T_c − t_blank and off for the last t_blank (0.2 s), during which the magnetometer
samples; the new dipole is applied at the cycle boundary. :class:`MagnetorquerCycle` gives the
phase from the step index (integers, so no rounding drift over long runs).

Reaction wheels and DC motors (Eqs. 8–11)
-----------------------------------------------
Per wheel, ω_M = hinge velocity (rotor speed relative to the bus):

    V_in − K_b ω_M = R_M i_M + L di_M/dt     (Eq. 8, armature; Eq. 9 back-emf V_b = K_b ω_M)
    I_w ω̇_rw + K_B ω_M = T_M                 (Eq. 10 corrected: rotor inertial spin rate)
    T_M = K_M i_M                             (Eq. 11)

In MuJoCo the rotor is a hinged body: ``ctrl`` = T_M on the rotor (its reaction on the bus) and
the joint damping K_B gives the friction, so the bus receives −(T_M − K_B ω_M) about the wheel
axis and the gyroscopic coupling comes out of the multibody dynamics
(the reaction on the bus is −ḣ_w, not the printed +ḣ_rw of Eq. 1).

Wheel driver (Yoo et al. 2016, Eqs. 8–11), :class:`WheelDriver`:

1. (controller rate) motor torque wanted for a body torque u_j (rotor net torque −u_j, friction
   compensated): T_c = −u_j + K_B ω_M;
2. (controller rate) current command i_c = clip(T_c/K_M, ±i_max), held;
3. (every dynamics step) V_in = clip(R_M i_c + K_b ω_M, ±V_max) with the current ω_M;
   i_M from Eq. 8 — quasi-static (L → 0, default): i_M = (V_in − K_b ω_M)/R_M; or
   ``electrical="substep"``: Eq. 8 integrated by explicit Euler sub-steps (δt_sub ≤ L/(4 R_M),
   stable and within ~1e-3 of the exact exponential), the step torque being the mean current;
   T_M = K_M i_M;
4. (every dynamics step) speed limiter: if |ω_M| ≥ Ω_max and the net rotor torque T_M − K_B ω_M
   would increase |ω_M|, T_M = K_B ω_M (zero net rotor torque).

``model="ideal"``: T_M = clip(T_c, ±τ_max) held, with the same speed limiter (tests, speed).

Limits (the paper's text and Table 4 disagree; our defaults):
τ_max = 0.196 mN m, Ω_max = 7000 rpm (3.30 mN m s) by default; unloading
threshold 3000 rpm on the speed. Assumed motor constants (not in the paper): K_M = K_b = 6e-3,
R_M = 10 Ω, L = 1 mH, K_B = 1e-8 N m s/rad, V_max = 5 V, i_max = τ_max/K_M.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import mujoco
import numpy as np

from magsail_mj.checks import require_non_negative, require_positive
from magsail_mj.loads.base import StepState
from magsail_mj.vec3 import cross_f, mat_vec_f

__all__ = [
    "MTQ_LIMIT_SETS",
    "coil_dipole",
    "rod_demagnetising_factor",
    "rod_dipole",
    "saturate_per_axis",
    "saturate_uniform",
    "mtq_power",
    "MagnetorquerCycle",
    "MagnetorquerLoad",
    "DCMotorParams",
    "WheelDriver",
    "RPM",
]

RPM = 2.0 * math.pi / 60.0
"""One revolution per minute in rad/s."""

MTQ_LIMIT_SETS: dict[str, tuple[float, float, float]] = {
    "command": (0.2, 0.2, 0.1),
    "half_watt": (0.02, 0.02, 0.01),
}
"""Magnetorquer dipole limits [A m²] per axis (x rod, y rod, z air coil), Yoo et al. 2016."""


# ----------------------------------------------------------------------------- magnetorquers


def coil_dipole(*, turns: float, current_A: float, area_m2: float) -> float:
    """Air-coil dipole M = n i A [A m²] (paper Eq. 6)."""
    if turns < 0 or area_m2 < 0:
        raise ValueError(f"turns, area_m2: must be >= 0, got {turns!r}, {area_m2!r}")
    return float(turns * current_A * area_m2)


def rod_demagnetising_factor(length_to_radius: float) -> float:
    """Demagnetising factor of a cylinder of length/radius ratio ℓ: N_d ≈ 4(ln ℓ − 1)/(ℓ² − 4 ln ℓ)
    (≈ 0.032 for the Table 5 rod; ℓ = 60 mm / 4 mm = 15)."""
    l = float(length_to_radius)
    if not l > 2.0:
        raise ValueError(f"length_to_radius: the approximation needs ℓ > 2, got {length_to_radius!r}")
    return 4.0 * (math.log(l) - 1.0) / (l * l - 4.0 * math.log(l))


def rod_dipole(*, turns: float, current_A: float, radius_m: float, mu_r: float, N_d: float) -> float:
    """Cored-rod dipole M = π r² n i [1 + (μ_r − 1)/(1 + (μ_r − 1) N_d)] [A m²] (paper Eq. 7)."""
    if not radius_m > 0:
        raise ValueError(f"radius_m: must be > 0, got {radius_m!r}")
    if mu_r < 1:
        raise ValueError(f"mu_r: relative permeability must be >= 1, got {mu_r!r}")
    if not 0 <= N_d <= 1:
        raise ValueError(f"N_d: demagnetising factor must be in [0, 1], got {N_d!r}")
    gain = 1.0 + (mu_r - 1.0) / (1.0 + (mu_r - 1.0) * N_d)
    return float(math.pi * radius_m**2 * turns * current_A * gain)


def saturate_per_axis(m: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """Clip each component of ``m`` to ±``limit`` independently (B-dot, Yoo et al. 2016, Eqs. 5–7)."""
    lim = np.asarray(limit, dtype=float)
    return np.clip(np.asarray(m, dtype=float), -lim, lim)


def saturate_uniform(m: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """Scale ``m`` down uniformly so that no axis exceeds its limit (unloading, Yoo et al. 2016, Eqs. 5–7);
    keeps the direction of m and therefore of the torque m × B."""
    m = np.asarray(m, dtype=float)
    lim = np.asarray(limit, dtype=float)
    ratio = float(np.max(np.abs(m) / lim))
    return m / ratio if ratio > 1.0 else m.copy()


def mtq_power(m: np.ndarray, limit: np.ndarray, *, power_max_W: float = 0.5) -> np.ndarray:
    """Electrical power per axis P_j = P_max (M_j/M_j,max)² [W] (assumed resistive model;
    reporting only). Works on (3,) or (T, 3) arrays."""
    return power_max_W * (np.asarray(m, dtype=float) / np.asarray(limit, dtype=float)) ** 2


@dataclass(frozen=True)
class MagnetorquerCycle:
    """The magnetorquer duty cycle with magnetometer blanking (Yoo et al. 2016, Eqs. 5–7).

    The cycle of ``cycle_s`` starts at t = 0; the magnetometer samples at each boundary
    t_k = k·cycle_s, the new dipole is on during [t_k, t_k + cycle_s − blank_s) and the coils are
    off during the last ``blank_s``. Times are handled as integer step counts of ``timestep_s``
    (both durations must be whole multiples of it).
    """

    cycle_s: float = 2.0
    blank_s: float = 0.2
    timestep_s: float = 0.1

    def __post_init__(self) -> None:
        if not self.timestep_s > 0:
            raise ValueError(f"timestep_s: must be > 0, got {self.timestep_s!r}")
        if not self.cycle_s > 0:
            raise ValueError(f"cycle_s: must be > 0, got {self.cycle_s!r}")
        if not 0 <= self.blank_s < self.cycle_s:
            raise ValueError(f"blank_s: must be in [0, cycle_s = {self.cycle_s}), got {self.blank_s!r}")
        for key in ("cycle_s", "blank_s"):
            n = getattr(self, key) / self.timestep_s
            if abs(n - round(n)) > 1e-9 * max(1.0, n):
                raise ValueError(
                    f"{key}: must be a whole multiple of the timestep {self.timestep_s} s, got {getattr(self, key)!r}"
                )
        n_cycle = int(round(self.cycle_s / self.timestep_s))
        object.__setattr__(self, "steps_per_cycle", n_cycle)
        object.__setattr__(self, "steps_on", n_cycle - int(round(self.blank_s / self.timestep_s)))

    steps_per_cycle: int = field(init=False, repr=False, compare=False)
    """Dynamics steps per magnetorquer cycle."""
    steps_on: int = field(init=False, repr=False, compare=False)
    """Steps per cycle with the coils energised."""

    @property
    def duty(self) -> float:
        """Fraction of the time the coils are on, (T_c − t_blank)/T_c."""
        return self.steps_on / self.steps_per_cycle

    def is_sample(self, step: int) -> bool:
        """Magnetometer sample and new dipole at this step (cycle boundary)."""
        return step % self.steps_per_cycle == 0

    def is_on(self, step: int) -> bool:
        """Coils energised during this step."""
        return step % self.steps_per_cycle < self.steps_on


class MagnetorquerLoad:
    """Adds the magnetorquer torque R M × B_eci on the bus (paper Eq. 5).

    The effective dipole (zero in the blanking window) is read from the held command
    ``state.ctrl.dipole_body`` [A m², body axes] (the CNUSAIL controller's command) or
    ``state.ctrl.dipole_body_Am2`` (a :class:`~magsail_mj.commands.MagneticDipole`); no command
    means no torque.
    """

    name = "magnetorquer"

    def __init__(self, body_id: int) -> None:
        self.body_id = int(body_id)
        self._R = np.zeros(9)  # scratch for mju_quat2Mat; zeros keep every build identical

    def torque_world(self, state: StepState) -> np.ndarray:
        """World-frame torque [N m] at this state."""
        return np.array(self._torque(state))

    def _torque(self, state: StepState) -> tuple[float, float, float]:
        """(R m) × B_eci in plain floats (:mod:`magsail_mj.vec3`); zeros without a dipole."""
        cmd = state.ctrl
        m = getattr(cmd, "dipole_body", None)
        if m is None:
            m = getattr(cmd, "dipole_body_Am2", None)
        if m is None or not (m[0] or m[1] or m[2]):
            return (0.0, 0.0, 0.0)
        mujoco.mju_quat2Mat(self._R, state.xquat[self.body_id])
        m = m.tolist() if isinstance(m, np.ndarray) else m
        return cross_f(mat_vec_f(self._R.tolist(), m), state.env.B_eci.tolist())

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        T = self._torque(state)
        if T[0] or T[1] or T[2]:
            i = self.body_id
            xfrc[i, 3] += T[0]
            xfrc[i, 4] += T[1]
            xfrc[i, 5] += T[2]


# ----------------------------------------------------------------------------- wheels


@dataclass(frozen=True)
class DCMotorParams:
    """Reaction-wheel and DC-motor constants (Yoo et al. 2016, Eqs. 8–11; defaults: the paper's values where
    it gives them, assumed otherwise).

    Attributes:
      spin_inertia_kgm2: rotor spin inertia I_w (Table 4: 4.5e-6).
      torque_max_Nm: τ_max (0.196e-3 default; 1.9e-3 sensitivity case).
      speed_max_rpm: Ω_max (7000 rpm default; 7500 alternative).
      K_M_Nm_A: motor torque constant K_M; K_b_Vs_rad: back-emf constant K_b (= K_M in SI).
      R_ohm: armature resistance R_M; L_H: inductance L.
      K_B_Nms: viscous bearing friction K_B.
      V_max_V: supply voltage limit.
      i_max_A: current limit (default τ_max/K_M).
    """

    spin_inertia_kgm2: float = 4.5e-6
    torque_max_Nm: float = 1.96e-4
    speed_max_rpm: float = 7000.0
    K_M_Nm_A: float = 6.0e-3
    K_b_Vs_rad: float = 6.0e-3
    R_ohm: float = 10.0
    L_H: float = 1.0e-3
    K_B_Nms: float = 1.0e-8
    V_max_V: float = 5.0
    i_max_A: float | None = None

    def __post_init__(self) -> None:
        require_positive(
            self,
            ("spin_inertia_kgm2", "torque_max_Nm", "speed_max_rpm", "K_M_Nm_A", "K_b_Vs_rad", "R_ohm", "V_max_V"),
        )
        require_non_negative(self, ("L_H", "K_B_Nms"))
        if self.i_max_A is not None and not self.i_max_A > 0:
            raise ValueError(f"i_max_A: must be > 0, got {self.i_max_A!r}")

    @property
    def current_max_A(self) -> float:
        """i_max (τ_max/K_M unless given)."""
        return self.i_max_A if self.i_max_A is not None else self.torque_max_Nm / self.K_M_Nm_A

    @property
    def speed_max_rad_s(self) -> float:
        return self.speed_max_rpm * RPM

    @property
    def momentum_max_Nms(self) -> float:
        """h_max = I_w Ω_max (3.30e-3 N m s with the defaults)."""
        return self.spin_inertia_kgm2 * self.speed_max_rad_s

    def steady_speed(self, V_in: float) -> float:
        """Relative speed for a constant voltage, bus held fixed, no current limit:
        ω_M = K_M V/(K_b K_M + K_B R_M) [rad/s]."""
        return self.K_M_Nm_A * V_in / (self.K_b_Vs_rad * self.K_M_Nm_A + self.K_B_Nms * self.R_ohm)

    def mechanical_time_constant(self) -> float:
        """τ = I_w R_M/(K_b K_M + K_B R_M) [s] of the constant-voltage spin-up (bus held fixed)."""
        return self.spin_inertia_kgm2 * self.R_ohm / (self.K_b_Vs_rad * self.K_M_Nm_A + self.K_B_Nms * self.R_ohm)

    def electrical_time_constant(self) -> float:
        """τ_e = L/R_M [s] (0.1 ms with the defaults)."""
        return self.L_H / self.R_ohm


class WheelDriver:
    """Wheel driver (Yoo et al. 2016, Eqs. 8–11) for the three wheels (vectorised over the wheels).

    Args:
      params: motor constants.
      model: ``"dc_motor"`` (default) or ``"ideal"`` (torque source clipped at ±τ_max).
      electrical: ``"quasi_static"`` (L → 0, default) or ``"substep"`` (Eq. 8 by explicit Euler
        sub-steps, ``n_substeps`` per dynamics step; default δt_sub ≤ L/(4 R_M)).
      n_substeps: sub-steps per dynamics step for ``"substep"`` (``None``: from δt_sub).

    Use :meth:`command` at the controller rate (steps 1–2) and :meth:`motor_torque` every
    dynamics step (steps 3–4). The armature current of the ``"substep"`` option is state
    (``self.current_A``).
    """

    def __init__(
        self,
        params: DCMotorParams | None = None,
        *,
        model: Literal["dc_motor", "ideal"] = "dc_motor",
        electrical: Literal["quasi_static", "substep"] = "quasi_static",
        n_substeps: int | None = None,
    ) -> None:
        if model not in ("dc_motor", "ideal"):
            raise ValueError(f"model: must be 'dc_motor' or 'ideal', got {model!r}")
        if electrical not in ("quasi_static", "substep"):
            raise ValueError(f"electrical: must be 'quasi_static' or 'substep', got {electrical!r}")
        if electrical == "substep" and not (params or DCMotorParams()).L_H > 0:
            raise ValueError("electrical: 'substep' needs an inductance L_H > 0")
        if n_substeps is not None and n_substeps < 1:
            raise ValueError(f"n_substeps: must be >= 1, got {n_substeps!r}")
        self.p = params or DCMotorParams()
        self.model = model
        self.electrical = electrical
        self.n_substeps = n_substeps
        self.current_A = np.zeros(3)

    # steps 1-2
    def command(self, u_body: np.ndarray, omega_M: np.ndarray) -> np.ndarray:
        """Held command for body torques ``u_body`` (3,) [N m]: the current command i_c [A]
        (``dc_motor``) or the motor torque T_c [N m] (``ideal``). T_c = −u + K_B ω_M."""
        p = self.p
        T_c = -np.asarray(u_body, dtype=float) + p.K_B_Nms * np.asarray(omega_M, dtype=float)
        if self.model == "ideal":
            return np.clip(T_c, -p.torque_max_Nm, p.torque_max_Nm)
        i_max = p.current_max_A
        return np.clip(T_c / p.K_M_Nm_A, -i_max, i_max)

    def idle_command(self) -> np.ndarray:
        """Zero command (wheels idle: i_c = 0, only bearing friction acts)."""
        return np.zeros(3)

    # steps 3-4
    def motor_torque(self, cmd: np.ndarray, omega_M: np.ndarray, dt: float) -> np.ndarray:
        """Motor torque T_M (3,) [N m] over the next dynamics step of length ``dt`` [s] for the
        held command ``cmd`` and the current relative speeds ``omega_M`` [rad/s]."""
        p = self.p
        if self.model == "dc_motor" and self.electrical == "quasi_static":
            return self._quasi_static_torque(cmd, omega_M)
        w = np.asarray(omega_M, dtype=float)
        if self.model == "ideal":
            T = np.asarray(cmd, dtype=float).copy()
        else:
            V = np.clip(p.R_ohm * np.asarray(cmd, dtype=float) + p.K_b_Vs_rad * w, -p.V_max_V, p.V_max_V)
            if self.electrical == "quasi_static":
                i = (V - p.K_b_Vs_rad * w) / p.R_ohm
                self.current_A = i
            else:
                i = self._substep_mean_current(V, w, dt)
            T = p.K_M_Nm_A * i
        return self.limit_speed(T, w)

    def _quasi_static_torque(self, cmd, omega_M) -> np.ndarray:
        """Steps 3–4 with L → 0 in plain floats (the per-step fast path; same equations)."""
        p = self.p
        R, Kb, KM, KB, Vm, wmax = p.R_ohm, p.K_b_Vs_rad, p.K_M_Nm_A, p.K_B_Nms, p.V_max_V, p.speed_max_rad_s
        c = cmd.tolist() if isinstance(cmd, np.ndarray) else cmd
        ws = omega_M.tolist() if isinstance(omega_M, np.ndarray) else omega_M
        out, cur = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
        for j in range(3):
            w = ws[j]
            V = R * c[j] + Kb * w
            V = Vm if V > Vm else (-Vm if V < -Vm else V)
            i = (V - Kb * w) / R
            T = KM * i
            if (w >= wmax or w <= -wmax) and (T - KB * w) * w > 0.0:
                T = KB * w
            cur[j] = i
            out[j] = T
        self.current_A = np.array(cur)
        return np.array(out)

    def _substep_mean_current(self, V: np.ndarray, w: np.ndarray, dt: float) -> np.ndarray:
        p = self.p
        n = self.n_substeps or max(1, math.ceil(dt / (p.L_H / p.R_ohm / 4.0)))
        h = dt / n
        i = self.current_A.copy()
        drive = (V - p.K_b_Vs_rad * w) / p.L_H
        decay = p.R_ohm / p.L_H
        acc = np.zeros(3)
        for _ in range(n):
            i_next = i + h * (drive - decay * i)
            acc += 0.5 * (i + i_next)
            i = i_next
        self.current_A = i
        return acc / n

    def limit_speed(self, T_M: np.ndarray, omega_M: np.ndarray) -> np.ndarray:
        """Step 4: where |ω_M| ≥ Ω_max and the net rotor torque T_M − K_B ω_M has the sign of ω_M,
        return T_M = K_B ω_M (zero net rotor torque)."""
        p = self.p
        net = T_M - p.K_B_Nms * omega_M
        stop = (np.abs(omega_M) >= p.speed_max_rad_s) & (net * omega_M > 0)
        return np.where(stop, p.K_B_Nms * omega_M, T_M)

    def body_torque(self, T_M: np.ndarray, omega_M: np.ndarray) -> np.ndarray:
        """Torque the wheels deliver to the bus about their axes: −(T_M − K_B ω_M) [N m]."""
        return -(np.asarray(T_M, dtype=float) - self.p.K_B_Nms * np.asarray(omega_M, dtype=float))
