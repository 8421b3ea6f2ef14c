r"""CNUSAIL-1 attitude control: command frames, mode logic and the sampled flight controller.

Source: Yoo et al. 2016, Sec. 5 (control laws, sampling, mode logic), with the paper's ambiguities
resolved where each rule is stated.

Command frames, as body → world rotation matrices (columns = command axes in ECI):

* nadir: the orbital frame R, ẑ_R = r̂, ŷ_R = (v × r)/|v × r|, x̂_R = ŷ_R × ẑ_R (≈ −v̂), each row normalised;
* deorbit: R turned by −90° about ŷ_R (active): x̂_C = ẑ_R, ŷ_C = ŷ_R, ẑ_C = −x̂_R ≈ +v̂, so the sail
  front face looks along the flight direction. From the nadir attitude the error is the paper's
  [0, 0.7071, 0, 0.7071] (scalar-last): the satellite starts in the nadir attitude.

Mode logic (:class:`ModeManager`)::

    any mode: |ω| > 1 °/s                      → DETUMBLE (B-dot, wheels idle)
    DETUMBLE: |ω| < ω_exit for t_dwell         → NADIR (eigen-axis/PD + unloading)
              (0.3 °/s for 60 s, assumed)         (DEORBIT instead once t ≥ t_deorbit)
    NADIR:    t ≥ t_deorbit (end-of-mission)    → DEORBIT (eigen-axis + unloading + recalculation)

Stand-alone scenarios run one mode with switching disabled (``enabled = False``).

The controller (:class:`CnusailController`) is a :class:`magsail_mj.sim.Controller` sampled every
dynamics step (``period_s`` = δt); inside it keeps these rates with integer step counts:

* attitude law (and wheel-driver steps 1–2: current command, zero-order hold) every
  ``attitude_period_s`` (1 s; 0.1 s option) — mode logic runs at the same samples;
* magnetorquer cycle (B-dot or unloading) every 2 s with the blanking window
  (:class:`~magsail_mj.loads.actuators_cubesat.MagnetorquerCycle`);
* wheel-driver steps 3–4 (voltage clip, armature current, speed limiter) every dynamics step,
  written to ``data.ctrl`` (motor torques T_M) through the command's ``apply_ctrl``.

Its command object carries ``dipole_body`` (the effective dipole, zero while blanked) for
:class:`~magsail_mj.loads.actuators_cubesat.MagnetorquerLoad`. Sensors are ideal (true attitude,
rate, field and wheel speeds) unless noise is configured: white Gaussian magnetometer noise
[T, per axis] and gyro noise [rad/s, per axis], seeded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Literal, Mapping

import mujoco
import numpy as np

from magsail_mj.checks import require_non_negative
from magsail_mj.control.bdot import make_bdot, normalised_bdot_dipole
from magsail_mj.control.detumble_laws import bang_bang_dipole, bcross_dipole, nonmonotonic_dipole
from magsail_mj.control.detumble_plugins import BUILTIN_DETUMBLE_LAWS, check_params, detumble_law, plugin_dipole
from magsail_mj.concepts.cnusail.eigenaxis import (
    EigenAxisGains,
    GyroComp,
    eigen_angle_f,
    eigen_axis_gains,
    eigen_axis_torque,
    error_quaternion_f,
    rate_error_f,
)
from magsail_mj.concepts.cnusail.pd import pd_torque
from magsail_mj.concepts.cnusail.unloading import UnloadingLogic, unloading_dipole
from magsail_mj.quaternion import quat_from_matrix
from magsail_mj.loads.actuators_cubesat import MagnetorquerCycle, WheelDriver, saturate_per_axis, saturate_uniform
from magsail_mj.checkpoint import restorable

__all__ = [
    "Mode",
    "nadir_command_matrix",
    "deorbit_command_matrix",
    "command_quaternion",
    "command_frame",
    "ModeLogicParams",
    "ModeManager",
    "CnusailControlParams",
    "CnusailController",
    "CnusailCommand",
    "DETUMBLE_LAWS",
]

DEG = math.pi / 180.0

DETUMBLE_LAWS = BUILTIN_DETUMBLE_LAWS
"""The detumble mode's shipped laws (``control.bdot_law``; plug-ins: :mod:`magsail_mj.control.detumble_plugins`)."""


class Mode(IntEnum):
    """Attitude-control modes."""

    DETUMBLE = 0
    NADIR = 1
    DEORBIT = 2


def nadir_command_matrix(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Body → world matrix of the nadir command (frame R, rows normalised): columns x̂_R, ŷ_R, ẑ_R."""
    z = r / np.linalg.norm(r)
    y = np.cross(v, r)
    y = y / np.linalg.norm(y)
    x = np.cross(y, z)
    return np.column_stack([x, y, z])


def deorbit_command_matrix(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Body → world matrix of the deorbit command: columns ẑ_R, ŷ_R, −x̂_R."""
    M = nadir_command_matrix(r, v)
    return np.column_stack([M[:, 2], M[:, 1], -M[:, 0]])


def command_quaternion(mode: Mode | int, r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Scalar-first command quaternion (command → world) of ``mode`` (DETUMBLE uses nadir)."""
    M = deorbit_command_matrix(r, v) if int(mode) == Mode.DEORBIT else nadir_command_matrix(r, v)
    return quat_from_matrix(M)


def command_frame(mode: int, r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, float]:
    """Command quaternion (command → ECI, scalar-first, ``w ≥ 0``) and orbital rate ``ω_o = |r × v|/|r|²``
    [rad/s] for the reference position ``r`` [m] and velocity ``v`` [m/s] (ECI), in scalar arithmetic.

    Nadir frame R: ``ẑ = r̂``, ``ŷ = (v × r)/|v × r|``, ``x̂ = ŷ × ẑ``; deorbit: columns ``(ẑ, ŷ, −x̂)``
    (DETUMBLE uses nadir). The quaternion is Shepperd's: the column of ``K = 4 q qᵀ`` with the
    largest diagonal entry, normalised, sign ``w ≥ 0`` (as :func:`command_quaternion` through
    :func:`magsail_mj.quaternion.quat_from_matrix`, here without array overhead: the flight
    controller, the environments' plant and their observations evaluate it at every attitude sample).
    """
    rx, ry, rz = (float(a) for a in r)
    vx, vy, vz = (float(a) for a in v)
    rn = math.sqrt(rx * rx + ry * ry + rz * rz)
    z = (rx / rn, ry / rn, rz / rn)
    hx, hy, hz = vy * rz - vz * ry, vz * rx - vx * rz, vx * ry - vy * rx  # v × r
    hn = math.sqrt(hx * hx + hy * hy + hz * hz)
    y = (hx / hn, hy / hn, hz / hn)
    x = (y[1] * z[2] - y[2] * z[1], y[2] * z[0] - y[0] * z[2], y[0] * z[1] - y[1] * z[0])
    cols = (z, y, (-x[0], -x[1], -x[2])) if int(mode) == Mode.DEORBIT else (x, y, z)
    (r00, r10, r20), (r01, r11, r21), (r02, r12, r22) = cols
    K = (
        (1 + r00 + r11 + r22, r21 - r12, r02 - r20, r10 - r01),
        (r21 - r12, 1 + r00 - r11 - r22, r01 + r10, r02 + r20),
        (r02 - r20, r01 + r10, 1 - r00 + r11 - r22, r12 + r21),
        (r10 - r01, r02 + r20, r12 + r21, 1 - r00 - r11 + r22),
    )
    col = K[max(range(4), key=lambda i: K[i][i])]
    n = math.sqrt(sum(c * c for c in col))
    q = np.array(col) / n
    return (-q if q[0] < 0 else q), hn / (rn * rn)


@dataclass(frozen=True)
class ModeLogicParams:
    """Mode-switching thresholds.

    Attributes:
      enabled: switch modes (False: stay in the initial mode).
      detumble_entry_rad_s: |ω| above which DETUMBLE is entered (1 °/s).
      detumble_exit_rad_s: |ω| below which the exit dwell runs (0.3 °/s).
      dwell_s: how long |ω| must stay below the exit threshold (60 s).
      deorbit_at_s: end-of-mission command time [s] (None: never).
    """

    enabled: bool = False
    detumble_entry_rad_s: float = 1.0 * DEG
    detumble_exit_rad_s: float = 0.3 * DEG
    dwell_s: float = 60.0
    deorbit_at_s: float | None = None

    def __post_init__(self) -> None:
        if not 0 < self.detumble_exit_rad_s <= self.detumble_entry_rad_s:
            raise ValueError(
                "detumble_exit_rad_s: must be > 0 and <= detumble_entry_rad_s, got "
                f"{self.detumble_exit_rad_s!r} (entry {self.detumble_entry_rad_s!r})"
            )
        if self.dwell_s < 0:
            raise ValueError(f"dwell_s: must be >= 0, got {self.dwell_s!r}")


class ModeManager:
    """The mode state machine (module docstring), evaluated at attitude samples."""

    def __init__(self, params: ModeLogicParams, *, initial: Mode) -> None:
        self.p = params
        self.mode = Mode(initial)
        self._below_since: float | None = None

    def update(self, t: float, omega_norm: float) -> tuple[Mode, bool]:
        """New mode at time ``t`` [s] for the measured body-rate norm [rad/s]; returns
        ``(mode, changed)``."""
        if not self.p.enabled:
            return self.mode, False
        old = self.mode
        p = self.p
        deorbit_due = p.deorbit_at_s is not None and t >= p.deorbit_at_s
        if omega_norm > p.detumble_entry_rad_s:
            self.mode = Mode.DETUMBLE
            self._below_since = None
        elif self.mode == Mode.DETUMBLE:
            if omega_norm < p.detumble_exit_rad_s:
                if self._below_since is None:
                    self._below_since = t
                if t - self._below_since >= p.dwell_s:
                    self.mode = Mode.DEORBIT if deorbit_due else Mode.NADIR
            else:
                self._below_since = None
        elif self.mode == Mode.NADIR and deorbit_due:
            self.mode = Mode.DEORBIT
        return self.mode, self.mode != old


@dataclass
class CnusailControlParams:
    """Everything the flight controller needs (SI units).

    Attributes:
      timestep_s: dynamics step δt.
      law: pointing law ``"eigen_axis"`` or ``"pd"`` (stand-alone ``"bdot"`` means detumbling).
      command: stand-alone pointing command ``"nadir"`` or ``"deorbit"``.
      attitude_period_s: attitude-law sample period (1 s).
      mtq_cycle: magnetorquer cycle with blanking.
      mtq_limits_Am2: (3,) dipole limits.
      bdot_form, bdot_gain, bdot_omega_c_rad_s: B-dot law (Yoo et al. 2016, Eqs. 24–27).
      bdot_normalised_gain_Am2s: when given, the proportional law is M = −k Ḃ/‖B‖ with this k
        [A m² s] (Willis et al. 2024's B-dot) in place of −K Ḃ.
      bdot_law: the detumble mode's law (:data:`DETUMBLE_LAWS`): ``"proportional"`` (the paper's
        M = −K Ḃ), ``"bang_bang"``, ``"b_cross"`` (B×ω, gain ``bcross_gain_Nms``) or
        ``"non_monotonic"`` (Willis et al. 2024; ``nonmonotonic_gain_per_Nms``, ``nonmonotonic_alpha``,
        the field ``nonmonotonic_lookahead_s`` ahead, from the table or extrapolated,
        ``nonmonotonic_field_ahead``); :mod:`magsail_mj.control.detumble_laws`;
        or the name of a plug-in law (:mod:`magsail_mj.control.detumble_plugins`) with its
        ``bdot_law_params``.
      omega_n_rad_s, zeta, rate_max_rad_s, clamp_min, gyro_comp, shortest_rotation: eigen-axis
        (Yoo et al. 2016, Eqs. 28–38).
      recalc_enabled, recalc_margin_rad: deorbit gain recalculation.
      unloading_enabled, k_rw_per_s, unload_on_rpm, unload_off_rpm: unloading (Yoo et al. 2016, Eq. 39).
      inertia_kgm2: (3, 3) spacecraft inertia J used by the laws.
      wheel_driver: the wheel driver (motor model and limits).
      modes: mode-switching parameters.
      magnetometer_noise_T, gyro_noise_rad_s: sensor noise σ per axis (0 = ideal).
      seed: noise seed.
    """

    timestep_s: float
    law: Literal["bdot", "eigen_axis", "pd"]
    command: Literal["nadir", "deorbit"] = "nadir"
    attitude_period_s: float = 1.0
    mtq_cycle: MagnetorquerCycle = field(default_factory=MagnetorquerCycle)
    mtq_limits_Am2: np.ndarray = field(default_factory=lambda: np.array([0.2, 0.2, 0.1]))
    bdot_form: Literal["finite_difference", "filtered"] = "finite_difference"
    bdot_gain: float = 5.0e4
    bdot_normalised_gain_Am2s: float | None = None
    bdot_omega_c_rad_s: float = 0.5
    bdot_law: str = "proportional"
    bdot_law_params: Mapping[str, float] = field(default_factory=dict)
    bcross_gain_Nms: float = 1.0e-3
    nonmonotonic_gain_per_Nms: float = 3.0e3
    nonmonotonic_alpha: float = 100.0
    nonmonotonic_lookahead_s: float = 600.0
    nonmonotonic_field_ahead: Literal["table", "extrapolated"] = "table"
    omega_n_rad_s: float = 0.02
    zeta: float = 0.9
    rate_max_rad_s: float = 0.3 * DEG
    clamp_min: float = 0.1
    gyro_comp: GyroComp = "Iw"
    shortest_rotation: bool = True
    recalc_enabled: bool = False
    recalc_margin_rad: float = 20.0 * DEG
    unloading_enabled: bool = True
    k_rw_per_s: float = 0.005
    unload_on_rpm: float = 3000.0
    unload_off_rpm: float | None = None
    inertia_kgm2: np.ndarray = field(default_factory=lambda: np.diag([0.3104, 0.3121, 0.5757]))
    wheel_driver: WheelDriver = field(default_factory=WheelDriver)
    modes: ModeLogicParams = field(default_factory=ModeLogicParams)
    magnetometer_noise_T: float = 0.0
    gyro_noise_rad_s: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if self.law not in ("bdot", "eigen_axis", "pd"):
            raise ValueError(f"law: must be 'bdot', 'eigen_axis' or 'pd', got {self.law!r}")
        if self.bdot_law not in DETUMBLE_LAWS:
            detumble_law(self.bdot_law)  # a plug-in, or ValueError naming the key and the laws known
        elif self.bdot_law_params:
            raise ValueError(f"bdot_law_params: the shipped law {self.bdot_law!r} takes none; they are a plug-in's")
        self.bdot_law_params = check_params(self.bdot_law_params, key="bdot_law_params")
        if self.command not in ("nadir", "deorbit"):
            raise ValueError(f"command: must be 'nadir' or 'deorbit', got {self.command!r}")
        n = self.attitude_period_s / self.timestep_s
        if not self.attitude_period_s > 0 or abs(n - round(n)) > 1e-9 * max(1.0, n):
            raise ValueError(
                f"attitude_period_s: must be a positive whole multiple of the timestep "
                f"{self.timestep_s} s, got {self.attitude_period_s!r}"
            )
        if abs(self.mtq_cycle.timestep_s - self.timestep_s) > 1e-12:
            raise ValueError(
                f"mtq_cycle: its timestep_s {self.mtq_cycle.timestep_s} must equal timestep_s {self.timestep_s}"
            )
        if self.modes.enabled and self.law == "bdot":
            raise ValueError(
                "law: with mode switching enabled, give the pointing law ('eigen_axis' or 'pd'); "
                "B-dot is the detumbling mode's law"
            )
        require_non_negative(self, ("magnetometer_noise_T", "gyro_noise_rad_s"))
        self.mtq_limits_Am2 = np.asarray(self.mtq_limits_Am2, dtype=float).reshape(3)
        self.inertia_kgm2 = np.asarray(self.inertia_kgm2, dtype=float).reshape(3, 3)

    @property
    def initial_mode(self) -> Mode:
        if self.law == "bdot":
            return Mode.DETUMBLE
        return Mode.DEORBIT if self.command == "deorbit" else Mode.NADIR


@restorable
class CnusailCommand:
    """The held command: the effective magnetorquer dipole (``dipole_body`` [A m²], body axes,
    zero while blanked) and, through :meth:`apply_ctrl`, the per-step wheel-driver update."""

    def __init__(self, controller: "CnusailController") -> None:
        self.controller = controller
        self.dipole_body = np.zeros(3)
        self.state: Any = None

    def apply_ctrl(self, data: mujoco.MjData) -> None:
        self.controller.step(self.state, data)


class CnusailController:
    """The CNUSAIL-1 flight controller (module docstring).

    Args:
      params: :class:`CnusailControlParams`.
      q_quat, v_ang: the bus quaternion qpos slice and body-rate qvel slice.
      wheel_qvel: (3,) qvel indices of the wheel hinges (relative speeds ω_M).
      wheel_act: (3,) actuator ids of the wheel motors.
      environment: the :class:`~magsail_mj.environment.environment.Environment` whose field table the
        non-monotonic law reads ahead (``sample(t).B_eci`` [T, ECI]; needed by that law only).

    Telemetry (updated every step, read by probes): ``mode``, ``p_e`` (error quaternion w.r.t.
    the active command; nadir in DETUMBLE), ``theta_e``, ``omega_e``, ``u`` (commanded body torque),
    ``wheel_cmd`` (held current [A] or torque [N m] command), ``T_M`` (motor torques),
    ``dipole_held`` (last commanded dipole), ``unload_mask``, ``B_meas`` (last magnetometer
    reading), ``gains``, ``theta_ref``, ``events`` (manoeuvre starts, gain recalculations, mode
    changes: dicts with ``t_s``, ``kind``, ``theta_rad`` …).
    """

    def __init__(
        self, params: CnusailControlParams, *, q_quat: slice, v_ang: slice, wheel_qvel, wheel_act, environment=None
    ) -> None:
        if params.bdot_law == "non_monotonic" and environment is None:
            raise ValueError("environment: the non-monotonic detumble law reads the field ahead; give the environment")
        self.p = params
        self.environment = environment if params.bdot_law == "non_monotonic" else None
        self.period_s = params.timestep_s
        self.q_quat, self.v_ang = q_quat, v_ang
        self.wheel_qvel = np.asarray(wheel_qvel, dtype=int)
        self.wheel_act = np.asarray(wheel_act, dtype=int)
        self.n_att = int(round(params.attitude_period_s / params.timestep_s))
        # per-step constants: the step, the cycle in steps, and the wheels' qvel / ctrl as slices
        # where contiguous (a slice reads and writes without NumPy's fancy-index path)
        self._dt = float(params.timestep_s)
        self._n_cycle = params.mtq_cycle.steps_per_cycle
        self._n_on = params.mtq_cycle.steps_on
        self._wheel_v = _slice_if_contiguous(self.wheel_qvel)
        self._wheel_u = _slice_if_contiguous(self.wheel_act)
        self.modes = ModeManager(params.modes, initial=params.initial_mode)
        self.bdot = make_bdot(
            params.bdot_form,
            gain=params.bdot_gain,
            sample_period_s=params.mtq_cycle.cycle_s,
            omega_c_rad_s=params.bdot_omega_c_rad_s,
        )
        self.unload = UnloadingLogic(on_rpm=params.unload_on_rpm, off_rpm=params.unload_off_rpm)
        self.driver = params.wheel_driver
        self.I_w = self.driver.p.spin_inertia_kgm2
        self.rng = np.random.default_rng(params.seed)
        self.cmd = CnusailCommand(self)
        self._R = np.zeros(9)  # scratch for mju_quat2Mat; zeros keep every build identical
        self._zero3 = np.zeros(3)
        self._last_att = -1
        self._last_mtq = -1
        # telemetry
        self.mode = self.modes.mode
        self.p_e = np.array([1.0, 0.0, 0.0, 0.0])
        self.theta_e = 0.0
        self.omega_e = np.zeros(3)
        self.u = np.zeros(3)
        self.wheel_cmd = self.driver.idle_command()
        self.T_M = np.zeros(3)
        self.dipole_held = np.zeros(3)
        self.unload_mask = np.zeros(3, dtype=bool)
        self.B_meas = np.zeros(3)
        self.gains: EigenAxisGains | None = None
        self.theta_ref = math.nan
        self.events: list[dict[str, Any]] = []
        self._start_pending = params.initial_mode != Mode.DETUMBLE

    # ---------------------------------------------------------------- runner protocol
    def update(self, state) -> CnusailCommand:
        """Runner hook (every step): remember the state; :meth:`CnusailCommand.apply_ctrl` does the work."""
        self.cmd.state = state
        return self.cmd

    def step(self, state, data: mujoco.MjData) -> None:
        """One dynamics step: attitude sample and magnetorquer cycle when due, then the wheel
        driver's per-step part (Yoo et al. 2016, Eqs. 8–11) into ``data.ctrl``."""
        k = int(round(state.t / self._dt))
        # a sample is due when a sample boundary was reached since the last call (robust to a
        # runner that skips a step of this every-step controller)
        i_att, i_mtq = k // self.n_att, k // self._n_cycle
        if i_att > self._last_att or i_mtq > self._last_mtq:
            self._samples(state, data, i_att, i_mtq)
        self.cmd.dipole_body = self.dipole_held if k % self._n_cycle < self._n_on else self._zero3
        self.T_M = self.driver.motor_torque(self.wheel_cmd, data.qvel[self._wheel_v].tolist(), self._dt)
        data.ctrl[self._wheel_u] = self.T_M

    def _samples(self, state, data: mujoco.MjData, i_att: int, i_mtq: int) -> None:
        """The attitude sample (``i_att`` new) and the magnetorquer sample (``i_mtq`` new) of this step."""
        p = self.p
        att, mtq = i_att > self._last_att, i_mtq > self._last_mtq
        self._last_att, self._last_mtq = max(self._last_att, i_att), max(self._last_mtq, i_mtq)
        omega_M = data.qvel[self.wheel_qvel]
        q = data.qpos[self.q_quat].copy()
        env = state.env
        if att:
            omega = data.qvel[self.v_ang].copy()
            if p.gyro_noise_rad_s > 0:
                omega = omega + self.rng.normal(0.0, p.gyro_noise_rad_s, 3)
            self._attitude_sample(state.t, q, omega, omega_M, env)
        if mtq:
            mujoco.mju_quat2Mat(self._R, q)
            self._mtq_sample(state.t, self._R.reshape(3, 3), omega_M, env, data.qvel[self.v_ang].copy())

    # ---------------------------------------------------------------- samples
    def _attitude_sample(self, t: float, q: np.ndarray, omega: np.ndarray, omega_M: np.ndarray, env) -> None:
        p = self.p
        old = self.modes.mode
        om = omega.tolist()
        mode, changed = self.modes.update(t, math.sqrt(om[0] * om[0] + om[1] * om[1] + om[2] * om[2]))
        self.mode = mode
        if changed:
            self.events.append({"t_s": t, "kind": "mode", "from": old.name, "to": mode.name})
            if mode == Mode.DETUMBLE:
                self.bdot.reset()
        # the telemetry in plain floats (:func:`command_frame`, the ``*_f`` forms of eigenaxis)
        p_c, w_o = command_frame(mode, env.r_ref_eci, env.v_ref_eci)
        p_e = error_quaternion_f(p_c.tolist(), q.tolist(), shortest=p.shortest_rotation)
        self.p_e = np.array(p_e)
        self.theta_e = eigen_angle_f(p_e)
        self.omega_e = rate_error_f(om, p_e, w_o)
        if mode == Mode.DETUMBLE:
            self.u = np.zeros(3)
            self.wheel_cmd = self.driver.idle_command()
            self._start_pending = True
            return
        q_e = self.p_e[1:]
        if self._start_pending or changed:
            self._set_gains(t, q_e, "manoeuvre_start")
            self.theta_ref = self.theta_e
            self._start_pending = False
        elif p.recalc_enabled and mode == Mode.DEORBIT and self.theta_e > self.theta_ref + p.recalc_margin_rad:
            self._set_gains(t, q_e, "gain_recalc")
            self.theta_ref = self.theta_e
        J = p.inertia_kgm2
        h_w = self.I_w * omega_M
        if p.law == "pd":
            self.u = pd_torque(q_e, self.omega_e, J, k=self.gains.k, c=self.gains.c)
        else:
            self.u = eigen_axis_torque(q_e, self.omega_e, omega, J, self.gains, gyro_comp=p.gyro_comp, h_w=h_w)
        self.wheel_cmd = self.driver.command(self.u, omega_M)

    def _set_gains(self, t: float, q_e: np.ndarray, kind: str) -> None:
        p = self.p
        self.gains = eigen_axis_gains(
            q_e, omega_n_rad_s=p.omega_n_rad_s, zeta=p.zeta, rate_max_rad_s=p.rate_max_rad_s, clamp_min=p.clamp_min
        )
        self.events.append(
            {
                "t_s": t,
                "kind": kind,
                "theta_rad": self.theta_e,
                "q_e": q_e.tolist(),
                "mode": self.mode.name,
                **self.gains.as_dict(),
            }
        )

    def _mtq_sample(self, t: float, R: np.ndarray, omega_M: np.ndarray, env, omega: np.ndarray) -> None:
        p = self.p
        B = R.T @ env.B_eci
        if p.magnetometer_noise_T > 0:
            B = B + self.rng.normal(0.0, p.magnetometer_noise_T, 3)
        self.B_meas = B
        m_bdot = self.bdot.update(B)
        if self.mode == Mode.DETUMBLE:
            self.unload_mask = np.zeros(3, dtype=bool)
            if p.bdot_law != "proportional":
                m = self._detumble_dipole(t, R, B, omega, env=env)
            elif p.bdot_normalised_gain_Am2s is not None:
                m = normalised_bdot_dipole(self.bdot.B_dot, B, gain_Am2s=p.bdot_normalised_gain_Am2s)
            else:
                m = m_bdot
            self.dipole_held = saturate_per_axis(m, p.mtq_limits_Am2)
        elif p.unloading_enabled:
            self.unload_mask = self.unload.update(omega_M)
            dh = np.where(self.unload_mask, self.I_w * omega_M, 0.0)
            m = unloading_dipole(dh, B, k_rw=p.k_rw_per_s) if self.unload_mask.any() else np.zeros(3)
            self.dipole_held = saturate_uniform(m, p.mtq_limits_Am2)
        else:
            self.unload_mask = np.zeros(3, dtype=bool)
            self.dipole_held = np.zeros(3)

    def _detumble_dipole(self, t: float, R: np.ndarray, B: np.ndarray, omega: np.ndarray, *, env: Any) -> np.ndarray:
        """The unsaturated dipole [A m²] of the detumble law ``bdot_law`` other than the
        proportional one (:mod:`magsail_mj.control.detumble_laws`), at the magnetometer sample:
        the field ``B`` [T, body], the rate ``omega`` [rad/s, body; gyro noise added when set] and,
        for the non-monotonic law, the field Δt = ``nonmonotonic_lookahead_s`` ahead in today's body
        axes: ``Rᵀ B(min(t + Δt, t_max))`` from the reference orbit's table (``"table"``; the
        table's last time ``t_max`` bounds the look-ahead near the end of a run, as the authors'
        interpolant clamps it) or ``Rᵀ (B(t) + Δt Ḃ(t))`` with B(t) and Ḃ(t) the orbit field and its
        rate [T, T/s, ECI] of the environment sample ``env`` at t (``"extrapolated"``, the
        ``bderivative_control`` of their Monte Carlo).
        Each law is evaluated on one row, as the batch evaluates it on every world's."""
        p = self.p
        if p.bdot_law == "bang_bang":
            return bang_bang_dipole(self.bdot.B_dot, p.mtq_limits_Am2)
        if p.gyro_noise_rad_s > 0:
            omega = omega + self.rng.normal(0.0, p.gyro_noise_rad_s, 3)
        if p.bdot_law == "b_cross":
            return bcross_dipole(omega[None], B[None], k_Nms=p.bcross_gain_Nms)[0]
        if p.bdot_law not in DETUMBLE_LAWS:
            return plugin_dipole(
                p.bdot_law,
                p.bdot_law_params,
                t_s=t,
                field_body_T=B,
                field_rate_body_T_s=self.bdot.B_dot,
                rate_body_rad_s=omega,
                inertia_kgm2=p.inertia_kgm2,
                dipole_max_Am2=p.mtq_limits_Am2,
            )
        if p.nonmonotonic_field_ahead == "extrapolated":
            B_ahead = R.T @ (env.B_eci + p.nonmonotonic_lookahead_s * env.B_dot_eci)
        else:
            t_ahead = min(t + p.nonmonotonic_lookahead_s, self.environment.t_max)
            B_ahead = R.T @ self.environment.sample(t_ahead).B_eci
        return nonmonotonic_dipole(
            omega[None],
            B[None],
            B_ahead[None],
            p.inertia_kgm2[None],
            gain_per_Nms=p.nonmonotonic_gain_per_Nms,
            alpha=p.nonmonotonic_alpha,
            m_max_Am2=p.mtq_limits_Am2,
        )[0]


def _slice_if_contiguous(index: np.ndarray) -> slice | np.ndarray:
    """``slice(i₀, i₀ + n)`` when ``index`` is ``i₀, i₀ + 1, …``, else ``index`` itself."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + int(index.size))
    return index
