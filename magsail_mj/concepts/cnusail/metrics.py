r"""CNUSAIL post-processing: derived series and the flat ``summary.json`` keys.

Definitions (time series recorded every ``sim.record_every`` steps, 1 s by default; "stays below X
after t" means every record from t on is below X; ``None`` when the last record is not):

Detumbling (``control.mode = "bdot"``):

* ``detumble_time_s``: time after which ‖ω‖ stays below ``analysis.detumble_threshold_deg_s``
  (0.3 °/s, the detumble exit threshold we assume; ‖ω‖ below it means every body-rate
  component is below it); ``detumble_time_below_{1p0,0p5,0p3,0p2}dps_s`` and ``…_orbits`` for the
  four thresholds;
* ``rate_mean_last_orbit_rad_s`` (mean ‖ω‖ over the last orbit), ``rate_ptp_last_two_orbits_rad_s``;
* ``mtq_energy_J``: ∫ Σ_j P_j dt over the coils' on-time, P_j = P_max (M_j/M_j,max)² (Yoo et al. 2016,
  Eqs. 5–7), each record's command held to the next record (:func:`held_on_integral`).
* ``mtq_dipole_effort_Am2s``: ∫‖m‖ dt of the applied dipole [A m² s], m the held dipole while
  the coils are on and 0 while blanked (:func:`dipole_effort`);
* ``detumble_time_h_1pct_s``: the first record time at which the body momentum ‖h‖ = ‖J ω‖ (J the
  composite principal inertia ``spacecraft.inertia_kgm2``, body axes) is below 1 % of its value at
  the first record (:func:`momentum_detumble_time`; Willis et al. 2024's criterion: *first* below,
  not *stays* below); ``detumbled_h_1pct`` whether it is reached within the run;
* ``detumbled``: with the stop rule (``sim.stop_rate_deg_s``) whether its hold condition was met
  (``stop_rule_time_s`` not ``None``), else whether ‖ω‖ stays below
  ``analysis.detumble_threshold_deg_s`` to the end (``detumble_time_s`` not ``None``).

Stop rule (every attitude run; ``None`` without ``sim.stop_rate_deg_s``): ``stop_rule_time_s``,
the first record time at which ‖ω‖ has stayed below ``sim.stop_rate_deg_s`` for
``sim.stop_hold_s`` (:func:`magsail_mj.sim.hold_below_time` on the records: where the rule ends the
run), and ``ended_by_stop_rule`` (the run completed at that time).

Pointing (``eigen_axis`` / ``pd``), θ_e the eigen-angle of the error quaternion, ω_e the rate error:

* ``eigen_angle_initial_rad``, ``slew_time_ideal_s`` = θ_e(0)/θ̇_max;
* ``slew_time_s`` = ``time_within_5deg_s``: time after which θ_e stays below 5°;
  ``time_within_5deg_over_ideal``;
* ``max_slew_rate_deg_s`` = ``rate_error_peak_rad_s`` (deg/s vs rad/s): max ‖ω_e‖;
  ``time_rate_above_1p05_limit_s``: time with ‖ω_e‖ > 1.05 θ̇_max;
* ``axis_deviation_max_rad``: angle between the instantaneous rotation axis −ω_e/‖ω_e‖ and the
  initial eigen-axis q_e(0)/‖q_e(0)‖ while θ_e > 5° and ‖ω_e‖ > 0.1 θ̇_max (the axis is undefined
  at rest); ``axis_deviation_max_cruise_rad`` the same while θ_e > 30° (the saturated cruise, before
  the linear end-game where the small residual rate is dominated by the orbital-rate coupling and the
  uncompensated wheel gyroscopic torque ω × h_w);
* ``pointing_error_max_deg`` = ``steady_error_max_rad`` (deg vs rad) and
  ``steady_rate_error_max_rad_s``: maxima after settling, t ≥ slew_time_s + settle margin
  (``analysis.settle_margin_s``, default 4/(ζω_n) = 222 s: the 2 % settling time of the small-angle
  loop); compare with the 5° and 0.1 °/s requirements;
* wheels: ``wheel_speed_max_rpm`` (all wheels), ``wheel_speed_max_{x,y,z}_rad_s``,
  ``wheel_time_at_speed_limit_{x,y,z}_s`` (|ω_M| ≥ 0.999 Ω_max), ``wheel_time_above_unload_{x,y,z}_s``,
  ``torque_saturated_time_s`` (some |u_j| > τ_max);
* unloading: ``unloading_active_fraction`` (fraction of the run with at least one axis unloading),
  ``unload_on_time_{x,y,z}_s``, ``unload_dipole_max_Am2`` (largest |m| commanded).

Deorbit (``control.command = "deorbit"``): ``sail_area_mean_m2`` (A_s |ẑ_B·V̂|),
``fraction_normal_within_5deg_of_flow`` (angle between ẑ_B and the flow direction V̂ = v_rel/|v_rel|),
``error_max_after_perigee_{k}_rad`` (max θ_e over the half orbit after the k-th perigee passage),
``gain_recalc_count`` (events with time, angle and gains in ``events.json``).

Disturbances (pointing runs, ``analysis.disturbance_orbit``): the torques of each source over one
orbit with the body held exactly in the nadir and in the deorbit attitude
(:func:`disturbance_orbit_profile`), ``disturbance_{source}_max_{nadir,deorbit}_Nm``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from magsail_mj.concepts.cnusail.modes import CnusailController, Mode, command_quaternion
from magsail_mj.estimation.attitude import euler_zyx, matrix_from_quat
from magsail_mj.loads.actuators_cubesat import MagnetorquerCycle, mtq_power
from magsail_mj.loads.base import StepState
from magsail_mj.concepts.cnusail.disturbances import SOURCES
from magsail_mj.quaternion import direction_quaternions, quat_mul
from magsail_mj.concepts.cnusail.model import CnusailModel
from magsail_mj.sim import RunResult, hold_below_time

__all__ = [
    "attitude_outputs",
    "time_stays_below",
    "time_first_below",
    "momentum_detumble_time",
    "dipole_effort",
    "disturbance_orbit_profile",
]

DEG = math.pi / 180.0
RPM = 2.0 * math.pi / 60.0


def time_stays_below(t: np.ndarray, x: np.ndarray, threshold: float) -> float | None:
    """First time from which ``x`` stays below ``threshold`` to the end (``None`` if the last
    record is not below; ``t[0]`` if it always is)."""
    above = np.flatnonzero(~(x < threshold))
    if above.size == 0:
        return float(t[0])
    k = int(above[-1])
    return None if k == len(t) - 1 else float(t[k + 1])


def time_first_below(t: np.ndarray, x: np.ndarray, threshold: float) -> float | None:
    """First time ``t_k`` with ``x_k < threshold`` (strictly below; ``None`` if no record is)."""
    below = np.flatnonzero(np.asarray(x) < threshold)
    return float(t[below[0]]) if below.size else None


def momentum_detumble_time(
    t: np.ndarray, omega_rad_s: np.ndarray, inertia_kgm2: np.ndarray, *, fraction: float = 0.01
) -> float | None:
    """First record time [s] at which ‖h‖ < ``fraction`` ‖h₀‖, with ``h = J ω`` [N m s] the body
    momentum of the rates ``omega_rad_s`` ((n, 3) [rad/s], body axes) recorded at ``t`` ((n,) [s]),
    ``J`` the inertia ``inertia_kgm2`` [kg m²] ((3,) principal moments or a (3, 3) matrix, body
    axes) and ``h₀`` the momentum at the first record; ``None`` if no record is below.

    Willis et al. (2024)'s detumble criterion: their Monte Carlo counts a run detumbled at the first
    sample whose ‖J ω‖ is below 1 % of its initial value (it may rise again afterwards)."""
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction: must be in (0, 1), got {fraction!r}")
    J = np.asarray(inertia_kgm2, dtype=float)
    w = np.asarray(omega_rad_s, dtype=float)
    h = w * J if J.shape == (3,) else w @ J.T
    h_norm = np.linalg.norm(h, axis=1)
    return time_first_below(np.asarray(t, dtype=float), h_norm, fraction * float(h_norm[0]))


def held_on_integral(t: np.ndarray, values: np.ndarray, *, cycle: MagnetorquerCycle) -> float:
    """∫ x dt over the coils' on-time of a quantity ``values`` (n,) recorded at the times ``t``
    (n,) [s] and held from each record to the next; the coils are on at the steps ``k`` with
    ``k mod N_c < N_on`` of ``cycle`` (N_c steps a cycle, the first N_on on, the rest blanked; step
    k at t = k δt), so

        ∫ x dt = Σ_{i<n−1} x_i δt (F(k_{i+1}) − F(k_i)),  F(k) = ⌊k/N_c⌋ N_on + min(k mod N_c, N_on),

    F(k) counting the on-steps before step k. Exact when every magnetometer sample (a multiple of
    N_c) is a record step (the record interval divides the cycle: 1 s records, 2 s cycle), since
    then the held command changes at records only; the last record ends the integral."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return 0.0
    k = np.rint(t / cycle.timestep_s).astype(np.int64)
    n_c, n_on = cycle.steps_per_cycle, cycle.steps_on
    on_before = (k // n_c) * n_on + np.minimum(k % n_c, n_on)
    on_s = np.diff(on_before) * cycle.timestep_s
    return float(np.sum(np.asarray(values, dtype=float)[:-1] * on_s))


def dipole_effort(t: np.ndarray, dipole: np.ndarray, *, cycle: MagnetorquerCycle) -> float:
    """∫‖m‖ dt [A m² s] of the applied dipole over the records: ``dipole`` (n, 3) the held dipole
    [A m², body] at the times ``t`` (n,) [s], integrated over the coils' on-time
    (:func:`held_on_integral`)."""
    norms = np.linalg.norm(np.asarray(dipole, dtype=float), axis=1) if len(dipole) else np.zeros(0)
    return held_on_integral(t, norms, cycle=cycle)


def _euler_321_deg(p_e: np.ndarray) -> np.ndarray:
    """3-2-1 (yaw, pitch, roll) angles [deg] of the error rotations (body relative to command)."""
    psi, theta, phi = euler_zyx(matrix_from_quat(p_e))
    return np.degrees(np.stack([psi, theta, phi], axis=1))


def disturbance_orbit_profile(
    sc: CnusailModel, mode: str, *, n: int = 600, offset_deg: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Disturbance torques (n, 4, 3) [N m, body axes, rows = SOURCES] over one orbit from t = 0 with
    the body held in the ``mode`` attitude (``"nadir"`` or ``"deorbit"``), turned by ``offset_deg``
    about the body y axis (0: exactly; then the gravity gradient vanishes, the principal axes being
    on R's axes), at times (n,). ``sc``: the built cubesat (an attitude task exposes the same
    ``environment``, ``orbit_period_s``, ``model``, ``idx`` and ``disturbances``)."""
    env = sc.environment
    T = min(sc.orbit_period_s, env.t_max)
    ts = np.linspace(0.0, T, n)
    nb = sc.model.nbody
    m = Mode.DEORBIT if mode == "deorbit" else Mode.NADIR
    out = np.empty((n, 4, 3))
    for i, t in enumerate(ts):
        e = env.sample(float(t))
        xq = np.tile([1.0, 0.0, 0.0, 0.0], (nb, 1))
        pc = command_quaternion(m, e.r_ref_eci, e.v_ref_eci)
        if offset_deg:
            h = math.radians(offset_deg) / 2
            pc = quat_mul(pc, np.array([math.cos(h), 0.0, math.sin(h), 0.0]))
        xq[sc.idx.bus] = pc
        st = StepState(
            t=float(t), pos=np.zeros((nb, 3)), vel=np.zeros((nb, 3)), xquat=xq, omega=np.zeros((nb, 3)), env=e
        )
        out[i] = sc.disturbances.torques_body(st)
    return ts, out


def attitude_outputs(
    sc: CnusailModel, result: RunResult, *, controller: CnusailController | None
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(summary, series) of an attitude run (module docstring) of the built cubesat ``sc`` whose
    flight controller was ``controller`` (its events and duty cycle; ``None``: not run)."""
    cfg, rec, idx = sc.cfg, result.records, sc.idx
    t = rec["t"]
    n = len(t)
    period = sc.orbit_period_s
    dt_rec = float(np.median(np.diff(t))) if n > 1 else cfg.sim.timestep_s
    qpos = rec["qpos"].copy()
    qvel = rec["qvel"]
    omega = qvel[:, idx.v_ang]
    wM = qvel[:, idx.wheel_qvel]
    Rb = matrix_from_quat(qpos[:, idx.q_quat])
    env = sc.environment.sample_many(t)
    B_body = np.einsum("tji,tj->ti", Rb, env["B_eci"])
    V = env["v_rel_eci"]
    V_hat = V / np.linalg.norm(V, axis=1, keepdims=True)
    z_b = Rb[:, :, 2]
    cos_flow = np.einsum("ti,ti->t", z_b, V_hat)
    wheels = cfg.actuators.wheels
    motor = wheels.motor_params()
    T_M = rec["T_M_Nm"]
    wheel_body = -(T_M - motor.K_B_Nms * wM)
    limits = cfg.actuators.mtq.limit_vector
    dip = rec["dipole_cmd_Am2"]
    power = mtq_power(dip, limits, power_max_W=cfg.actuators.mtq.power_max_W)
    p_e = rec["p_e"]
    theta = rec["theta_e_rad"]
    omega_e = rec["omega_e_rad_s"]

    # marker bodies of the video: Sun, velocity, nadir, field directions
    for name, vec in (
        ("mk_sun", env["sun_eci"]),
        ("mk_vel", env["v_ref_eci"]),
        ("mk_nadir", -env["r_ref_eci"]),
        ("mk_field", env["B_eci"]),
    ):
        if name in idx.marker_qpos:
            qa = idx.marker_qpos[name]
            if np.any(np.linalg.norm(vec, axis=1) > 0):
                qpos[:, qa : qa + 4] = direction_quaternions(vec)

    series: dict[str, np.ndarray] = {
        "qpos": qpos,
        "omega_body_rad_s": omega,
        "omega_norm_deg_s": np.degrees(np.linalg.norm(omega, axis=1)),
        "wheel_speed_rad_s": wM,
        "wheel_speed_rpm": wM / RPM,
        "theta_e_deg": np.degrees(theta),
        "error_321_deg": _euler_321_deg(p_e),
        "wheel_torque_body_Nm": wheel_body,
        "B_body_T": B_body,
        "mtq_power_W": power,
        "altitude_m": env["altitude_m"],
        "density_kg_m3": env["density_kg_m3"],
        "in_shadow": env["in_shadow"].astype(np.int8),
        "sail_flow_cos": cos_flow,
        "sail_normal_flow_angle_deg": np.degrees(np.arccos(np.clip(cos_flow, -1.0, 1.0))),
    }
    if cfg.spacecraft.configuration == "deployed":
        series["sail_area_m2"] = cfg.spacecraft.sail_area_m2 * np.abs(cos_flow)

    summary: dict[str, Any] = {
        "status": result.status,
        "t_end_s": result.t_end_s,
        "orbit_period_s": period,
        "wall_time_s": result.wall_time_s,
        "step_cost_us": 1e6 * result.wall_time_s / max(result.steps, 1),
    }
    summary.update(sc.environment.summary())
    w_norm = np.linalg.norm(omega, axis=1)
    summary["rate_initial_rad_s"] = float(w_norm[0])
    summary["wheel_speed_max_rpm"] = float(np.max(np.abs(wM)) / RPM)
    mask = rec["unload_mask"].astype(bool)
    summary["unloading_active_fraction"] = float(np.mean(mask.any(axis=1))) if n else 0.0
    stop_time = None
    if cfg.sim.stop_rate_deg_s is not None:
        stop_time = hold_below_time(
            t,
            omega,
            threshold=math.radians(cfg.sim.stop_rate_deg_s),
            hold_s=cfg.sim.stop_hold_s,
            tolerance_s=1e-6 * cfg.sim.timestep_s,
        )
        summary["stop_rule_time_s"] = stop_time
        summary["ended_by_stop_rule"] = result.status == "completed" and stop_time == result.t_end_s
    else:
        summary["stop_rule_time_s"] = summary["ended_by_stop_rule"] = None
    mode = cfg.control.mode
    summary["detumble_time_s"] = None
    for key in ("slew_time_s", "max_slew_rate_deg_s", "pointing_error_max_deg"):
        summary[key] = None

    if mode == "bdot" or cfg.control.modes.enabled:
        thr = cfg.analysis.detumble_threshold_deg_s * DEG
        summary["detumble_time_s"] = time_stays_below(t, w_norm, thr)
        for label, val in (("1p0", 1.0), ("0p5", 0.5), ("0p3", 0.3), ("0p2", 0.2)):
            ts = time_stays_below(t, w_norm, val * DEG)
            summary[f"detumble_time_below_{label}dps_s"] = ts
            summary[f"detumble_time_below_{label}dps_orbits"] = None if ts is None else ts / period
        last = t >= t[-1] - period
        summary["rate_mean_last_orbit_rad_s"] = float(np.mean(w_norm[last]))
        last2 = t >= t[-1] - 2 * period
        summary["rate_ptp_last_two_orbits_rad_s"] = float(np.ptp(w_norm[last2]))
        mtq = cfg.actuators.mtq
        cycle = MagnetorquerCycle(cycle_s=mtq.cycle_s, blank_s=mtq.blank_s, timestep_s=cfg.sim.timestep_s)
        summary["mtq_energy_J"] = held_on_integral(t, power.sum(axis=1), cycle=cycle)
        summary["mtq_dipole_max_Am2"] = float(np.max(np.abs(dip))) if n else 0.0
        summary["mtq_dipole_effort_Am2s"] = dipole_effort(t, dip, cycle=cycle)
        t_h = momentum_detumble_time(t, omega, np.asarray(cfg.spacecraft.inertia), fraction=0.01)
        summary["detumble_time_h_1pct_s"] = t_h
        summary["detumbled_h_1pct"] = t_h is not None
        rule = cfg.sim.stop_rate_deg_s is not None
        summary["detumbled"] = (stop_time if rule else summary["detumble_time_s"]) is not None

    if mode in ("eigen_axis", "pd"):
        c = cfg.control
        rate_max = c.slew_rate_max_deg_s * DEG
        thr = cfg.analysis.pointing_threshold_deg * DEG
        th0 = float(theta[0])
        summary["eigen_angle_initial_rad"] = th0
        summary["eigen_angle_initial_deg"] = math.degrees(th0)
        summary["slew_time_ideal_s"] = th0 / rate_max
        t5 = time_stays_below(t, theta, thr)
        summary["time_within_5deg_s"] = t5
        summary["slew_time_s"] = t5
        summary["time_within_5deg_over_ideal"] = None if t5 is None else t5 / (th0 / rate_max)
        we = np.linalg.norm(omega_e, axis=1)
        summary["rate_error_peak_rad_s"] = float(we.max())
        summary["max_slew_rate_deg_s"] = math.degrees(float(we.max()))
        summary["time_rate_above_1p05_limit_s"] = float(np.sum(we > 1.05 * rate_max) * dt_rec)
        e0 = p_e[0, 1:] / max(np.linalg.norm(p_e[0, 1:]), 1e-300)
        sel = (theta > thr) & (we > 0.1 * rate_max)
        if np.any(sel):
            ax = -omega_e[sel] / we[sel, None]
            summary["axis_deviation_max_rad"] = float(np.max(np.arccos(np.clip(ax @ e0, -1.0, 1.0))))
        else:
            summary["axis_deviation_max_rad"] = None
        series["axis_deviation_deg"] = np.where(
            sel, np.degrees(np.arccos(np.clip((-omega_e / np.maximum(we, 1e-300)[:, None]) @ e0, -1.0, 1.0))), np.nan
        )
        cruise = sel & (theta > 30 * DEG)
        summary["axis_deviation_max_cruise_rad"] = (
            float(np.radians(np.nanmax(series["axis_deviation_deg"][cruise]))) if np.any(cruise) else None
        )
        margin = cfg.analysis.settle_margin_s
        if margin is None:
            margin = 4.0 / (c.zeta * c.omega_n_rad_s)
        summary["settle_margin_s"] = margin
        if t5 is not None and np.any(t >= t5 + margin):
            steady = t >= t5 + margin
            summary["steady_error_max_rad"] = float(theta[steady].max())
            summary["pointing_error_max_deg"] = math.degrees(summary["steady_error_max_rad"])
            summary["steady_rate_error_max_rad_s"] = float(we[steady].max())
        else:
            summary["steady_error_max_rad"] = None
            summary["steady_rate_error_max_rad_s"] = None
        for j, a in enumerate("xyz"):
            summary[f"wheel_speed_max_{a}_rad_s"] = float(np.max(np.abs(wM[:, j])))
            summary[f"wheel_time_at_speed_limit_{a}_s"] = float(
                np.sum(np.abs(wM[:, j]) >= 0.999 * motor.speed_max_rad_s) * dt_rec
            )
            summary[f"wheel_time_above_unload_{a}_s"] = float(
                np.sum(np.abs(wM[:, j]) > c.unloading.threshold_rpm * RPM) * dt_rec
            )
            summary[f"unload_on_time_{a}_s"] = float(np.sum(mask[:, j]) * dt_rec)
        summary["torque_saturated_time_s"] = float(
            np.sum(np.any(np.abs(rec["u_cmd_Nm"]) > motor.torque_max_Nm, axis=1)) * dt_rec
        )
        un = np.linalg.norm(dip, axis=1)
        summary["unload_dipole_max_Am2"] = float(un[mask.any(axis=1)].max()) if mask.any() else 0.0
        summary["wheel_momentum_max_Nms"] = float(np.max(np.abs(wM)) * motor.spin_inertia_kgm2)

        if c.command == "deorbit" or c.modes.deorbit_at_s is not None:
            area = cfg.spacecraft.sail_area_m2 * np.abs(cos_flow)
            summary["sail_area_mean_m2"] = float(area.mean())
            summary["fraction_normal_within_5deg_of_flow"] = float(np.mean(cos_flow > math.cos(5 * DEG)))
            rn = np.linalg.norm(env["r_ref_eci"], axis=1)
            peri = [i for i in range(1, n - 1) if rn[i] <= rn[i - 1] and rn[i] < rn[i + 1]]
            for kk, i in enumerate(peri, start=1):
                win = (t >= t[i]) & (t <= t[i] + 0.5 * period)
                summary[f"error_max_after_perigee_{kk}_rad"] = float(theta[win].max())
                summary[f"perigee_{kk}_time_s"] = float(t[i])
            events = controller.events if controller is not None else []
            summary["gain_recalc_count"] = sum(1 for e in events if e["kind"] == "gain_recalc")
        if controller is not None:
            ms = [e for e in controller.events if e["kind"] == "manoeuvre_start"]
            if ms:
                summary["eigen_angle_gain_ref_rad"] = ms[0]["theta_clamped_rad"]
                # the gain clamp (components of |q_e0| below the floor raised to it): the eigen-angle
                # the gains were computed from vs the true one, and whether the clamp acted
                summary["eigen_angle_gain_true_rad"] = ms[0]["theta_true_rad"]
                summary["eigen_gain_clamped"] = bool(ms[0]["theta_clamped_rad"] != ms[0]["theta_true_rad"])

        if cfg.analysis.disturbance_orbit:
            for m in ("nadir", "deorbit"):
                ts, tq = disturbance_orbit_profile(sc, m)
                series[f"dist_orbit_t_{m}_s"] = ts
                series[f"dist_orbit_{m}_Nm"] = tq
                series[f"dist_orbit_{m}_gg_5deg_Nm"] = disturbance_orbit_profile(sc, m, n=120, offset_deg=5.0)[1][:, 0]
                series[f"dist_orbit_t_{m}_gg_5deg_s"] = np.linspace(0.0, ts[-1], 120)
                for k, src in enumerate(SOURCES):
                    summary[f"disturbance_{src}_max_{m}_Nm"] = float(np.max(np.linalg.norm(tq[:, k], axis=1)))

    dist = rec["torque_dist_body_Nm"]
    for k, src in enumerate(SOURCES):
        summary[f"disturbance_{src}_max_Nm"] = float(np.max(np.linalg.norm(dist[:, k], axis=1)))
    summary["mtq_torque_max_Nm"] = float(np.max(np.linalg.norm(rec["torque_mtq_body_Nm"], axis=1)))
    modes = rec["mode"].astype(int)
    for m in Mode:
        summary[f"time_in_{m.name.lower()}_s"] = float(np.sum(modes == int(m)) * dt_rec)
    if controller is not None:
        summary["event_count"] = len(controller.events)
    return summary, series
