r"""Reflector post-processing: derived series and the flat ``summary.json`` keys.

Records are taken every ``sim.record_every`` steps; "first time" metrics are the first record at
which the condition holds (``None`` if never).

Functions take the built plate (:class:`magsail_mj.concepts.reflector.model.ReflectorModel`:
config, indices, inertia, capability, orbit) and the run's records.

Detumble: ``t_omega_below_1e-{2,3,4}_s`` (first |ω| below 10⁻², 10⁻³, 10⁻⁴ rad/s; the alias
``time_rate_below_1e-3_s`` equals the middle one), ``omega_final_rad_s``,
``sat_fraction_{x,y}coil``, ``t_min_one_cap_s = |h₀| / T_max`` and ``t_min_two_caps_s =
|h₀| / (√2 T_max)`` (both paths saturated, field ⟂ both dipoles), ``h_along_B_change_Nms``
(change of h·B̂, world axes, which a magnetic torque cannot alter for an inertial field).

Pitch: attitude-error angle ``2 atan2(|q_e,xyz|, |q_e,w|)`` (= 2 arccos|q_e,w|, accurate near 0);
pitch ``ψ_act = π/2 − β_act`` with
``β_act = unwrap(atan2(R₁₃, R₁₁))``; ``t_err_above_{1,5}deg_s``, ``time_err_above_5deg_s``,
``err_max_rad``, ``err_rms_rad``, ``sat_fraction``, ``passes_over_cap`` (passes in which
|T_ref| exceeds the cap), ``torque_ff_peak_Nm`` (max I₂|ψ̈| over the nominal run) and the cross-concept keys
``tracking_lost_first_s`` (first |ψ − ψ_ref| > 5°), ``passes_saturated`` (passes with a
saturated record), ``psi_error_rms_deg``. A *pass* is the window ``t_k ± T_orb/2`` around an
equator crossing on the +x side, ``t_k = t_m + k T_orb``, clipped to the run.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from magsail_mj.control.reflector_steering import pitch_angle_from_quaternion
from magsail_mj.environment.frames import quat_to_mat
from magsail_mj.concepts.reflector.mjcf import plate_mass_properties
from magsail_mj.quaternion import direction_quaternions, quat_angle
from magsail_mj.concepts.reflector.model import ReflectorModel
from magsail_mj.sim import RunResult

__all__ = ["detumble_outputs", "pitch_outputs", "first_time", "pass_table", "reference_products"]

DEG = math.pi / 180.0


def first_time(t: np.ndarray, mask: np.ndarray) -> float | None:
    """First ``t`` where ``mask`` holds, ``None`` if never."""
    k = np.flatnonzero(mask)
    return float(t[k[0]]) if k.size else None


def _dt_weights(t: np.ndarray) -> np.ndarray:
    """Time each record stands for (forward differences, last = previous)."""
    if t.size < 2:
        return np.zeros_like(t)
    dt = np.diff(t)
    return np.append(dt, dt[-1])


def _run_summary(result: RunResult, plate: ReflectorModel) -> dict[str, Any]:
    """The summary entries every reflector run starts with: status, end time [s], wall time [s],
    wall time per step [µs] and the plate variant."""
    return {
        "status": result.status,
        "t_end_s": result.t_end_s,
        "wall_time_s": result.wall_time_s,
        "step_cost_us": 1e6 * result.wall_time_s / max(result.steps, 1),
        "variant": plate.cfg.variant,
    }


def _plate_records(plate: ReflectorModel, result: RunResult):
    """``(records, t, qpos, q, ω)``: the records, their times, a copy of ``qpos`` (the markers are
    written into it), the plate quaternions (a view of that copy) and the body rates."""
    rec = result.records
    qpos = rec["qpos"].copy()
    return rec, rec["t"], qpos, qpos[:, plate.idx.q_quat], rec["qvel"][:, plate.idx.v_ang]


def _set_markers(plate: ReflectorModel, qpos: np.ndarray, directions: dict[str, np.ndarray]) -> None:
    for name, vec in directions.items():
        qa = plate.idx.marker_qpos.get(name)
        if qa is None:
            continue
        v = np.asarray(vec, dtype=float)
        n = np.linalg.norm(v, axis=1)
        # hold the last defined direction where the vector vanishes (e.g. zero torque)
        ok = n > 1e-30
        if not ok.any():
            continue
        idx = np.where(ok, np.arange(len(v)), 0)
        idx = np.maximum.accumulate(idx)
        first = int(np.argmax(ok))
        idx[:first] = first
        qpos[:, qa : qa + 4] = direction_quaternions(v[idx])


# ------------------------------------------------------------------------------ detumble


def detumble_outputs(plate: ReflectorModel, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary and series of a Scenario A run."""
    rec, t, qpos, q, w = _plate_records(plate, result)
    R = quat_to_mat(q)
    I = plate.inertia
    h_b = w * I
    h_w = np.einsum("tij,tj->ti", R, h_b)
    B_b = rec["B_body_T"]
    B_w = np.einsum("tij,tj->ti", R, B_b)
    b_hat = B_w / np.maximum(np.linalg.norm(B_w, axis=1, keepdims=True), 1e-300)
    T_b = rec["torque_body_Nm"]
    T_w = np.einsum("tij,tj->ti", R, T_b)
    w_w = np.einsum("tij,tj->ti", R, w)
    w_norm = np.linalg.norm(w, axis=1)
    h_norm = np.linalg.norm(h_w, axis=1)
    h_along = np.einsum("ti,ti->t", h_w, b_hat)
    sat = rec["saturated"].astype(bool)
    _set_markers(plate, qpos, {"mk_field": B_w, "mk_omega": w_w, "mk_torque": T_w})
    series = {
        "qpos": qpos,
        "time_h": t / 3600.0,
        "omega_body_rad_s": w,
        "omega_norm_rad_s": w_norm,
        "q_wxyz": q,
        "h_world_Nms": h_w,
        "h_norm_Nms": h_norm,
        "h_along_B_Nms": h_along,
        "kinetic_energy_J": 0.5 * np.einsum("ti,ti->t", w, h_b),
        "T_norm_Nm": np.linalg.norm(T_b, axis=1),
        "torque_norm_Nm": np.linalg.norm(T_b, axis=1),  # video overlay (unit suffix it knows)
        "torque_body_Nm": T_b,
        "currents_A": rec["currents_A"],
        "B_world_T": B_w,
    }
    cap = plate.cap.cap_Nm
    h0 = float(h_norm[0])
    summary: dict[str, Any] = {
        **_run_summary(result, plate),
        "law": plate.cfg.control.law,
        "field_frame": plate.cfg.field.frame,
        "omega_k_rad_s": plate.cfg.control.omega_k_rad_s,
        "bdot_gain": plate.bdot_gain(),
        "T_max_Nm": cap,
        "m_max_Am2": float(plate.cap.m_max_Am2[1]),
        "mass_kg": plate.mass_kg,
        "inertia_kgm2": plate.inertia.tolist(),
        "omega_initial_rad_s": float(w_norm[0]),
    }
    for exp in (2, 3, 4):
        summary[f"t_omega_below_1e-{exp}_s"] = first_time(t, w_norm < 10.0**-exp)
    summary["time_rate_below_1e-3_s"] = summary["t_omega_below_1e-3_s"]
    summary["omega_final_rad_s"] = float(w_norm[-1])
    summary["sat_fraction_xcoil"] = float(np.mean(sat[:, 0]))
    summary["sat_fraction_ycoil"] = float(np.mean(sat[:, 1]))
    summary["t_min_one_cap_s"] = h0 / cap
    summary["t_min_two_caps_s"] = h0 / (math.sqrt(2.0) * cap)
    summary["h_initial_Nms"] = h0
    summary["h_final_Nms"] = float(h_norm[-1])
    summary["h_along_B_change_Nms"] = float(h_along[-1] - h_along[0])
    summary["kinetic_energy_initial_J"] = float(series["kinetic_energy_J"][0])
    summary["kinetic_energy_final_J"] = float(series["kinetic_energy_J"][-1])
    return summary, series


# ------------------------------------------------------------------------------ pitch


def reference_products(plate: ReflectorModel, *, dt_s: float = 1.0) -> dict[str, np.ndarray]:
    """Reference-only series over the nominal run ``[0, n_orbits T_orb]`` on a ``dt_s`` grid:
    ``t``, ``psi_c``, ``psi_wrapped``, ``psi_dot``, ``psi_ddot``, ``B`` (world, Eq. 11), and the
    feed-forward pitch torque ``I₂ |ψ̈|`` for σ = 100 and 10 g/m² (``torque_ff_sigma100``,
    ``torque_ff_sigma10``) and for the run's own density (``torque_ff``)."""
    o = plate.orbit
    t_f = plate.cfg.orbit.n_orbits * o.period_s
    t = np.arange(0.0, t_f + 0.5 * dt_s, dt_s)
    out: dict[str, np.ndarray] = {"t": t, **o.psi_series(t), "B": o.field(t)}
    p = plate.cfg.plate
    for label, sigma in (("sigma100", 0.1), ("sigma10", 0.01)):
        _, I = plate_mass_properties(side_m=p.side_m, areal_density_kg_m2=sigma, thickness_m=plate.params.thickness)
        out[f"torque_ff_{label}"] = I[1] * np.abs(out["psi_ddot"])
    out["torque_ff"] = plate.inertia[1] * np.abs(out["psi_ddot"])
    return out


def pass_windows(plate: ReflectorModel, t_end: float) -> list[tuple[int, float, float, float]]:
    """``(k, t_k, start, end)`` of each pass whose window meets ``[0, t_end]``."""
    o = plate.orbit
    T = o.period_s
    k_lo = math.floor((0.0 - o.t_mid_s) / T - 0.5) + 1
    k_hi = math.ceil((t_end - o.t_mid_s) / T + 0.5) - 1
    out = []
    for k in range(k_lo, k_hi + 1):
        tk = o.t_mid_s + k * T
        a, b = max(0.0, tk - T / 2), min(t_end, tk + T / 2)
        if b > a:
            out.append((k, tk, a, b))
    return out


def pass_table(plate: ReflectorModel, ref: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """Per-pass table of the reference: pass index k (0 = overhead), equator-crossing time,
    peak |ψ̇|, peak |ψ̈|, peak required torque I₂|ψ̈| and minutes above the cap, for both densities."""
    t = ref["t"]
    dt = _dt_weights(t)
    cap = plate.cap.cap_Nm
    rows = []
    for k, tk, a, b in pass_windows(plate, float(t[-1])):
        sel = (t >= a) & (t < b) if b < t[-1] else (t >= a) & (t <= b)
        row = {
            "pass": k,
            "t_equator_s": tk,
            "t_equator_h": tk / 3600.0,
            "psi_dot_peak_rad_s": float(np.max(np.abs(ref["psi_dot"][sel]))),
            "psi_ddot_peak_rad_s2": float(np.max(np.abs(ref["psi_ddot"][sel]))),
        }
        for label in ("sigma100", "sigma10"):
            tq = ref[f"torque_ff_{label}"][sel]
            row[f"torque_ff_peak_{label}_Nm"] = float(tq.max())
            row[f"minutes_above_cap_{label}"] = float(np.sum(dt[sel][tq > cap]) / 60.0)
        rows.append(row)
    return rows


def pitch_outputs(
    plate: ReflectorModel, result: RunResult, *, ref: dict[str, np.ndarray] | None = None
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary and series of a Scenario B run; ``ref``: :func:`reference_products` of ``plate``
    (computed when not given)."""
    rec, t, qpos, q, w = _plate_records(plate, result)
    o = plate.orbit
    q_e = rec["q_e"]
    err = quat_angle(q_e)
    beta_act = pitch_angle_from_quaternion(q)
    psi_act = 0.5 * np.pi - beta_act
    psi_ref = rec["psi_ref_rad"]
    # same branch as the reference at the first record (both start from the principal value), then
    # each is unwrapped on its own, so a lost track shows as a growing difference of whole turns
    psi_act = psi_act + 2 * np.pi * np.round((psi_ref[0] - psi_act[0]) / (2 * np.pi))
    dpsi = np.angle(np.exp(1j * (psi_act - psi_ref)))
    T_ref = rec["T_ref_body_Nm"]
    T_act = rec["torque_body_Nm"]
    sat = rec["saturated"].astype(bool)
    cap = plate.cap.cap_Nm
    r_w = o.position(t)
    R_g = o.ground_point(t)
    B_w = rec["B_world_T"]
    R = quat_to_mat(q)
    _set_markers(
        plate, qpos, {"mk_sun": np.tile([0.0, 1.0, 0.0], (t.size, 1)), "mk_ground": R_g - r_w, "mk_field": B_w}
    )
    qa = plate.idx.marker_qpos.get("mk_ref_line")
    if qa is not None:
        qpos[:, qa : qa + 4] = rec["q_ref"]
    series = {
        "qpos": qpos,
        "time_h": t / 3600.0,
        "theta_rad": o.theta(t),
        "phi_rad": o.phi(t),
        "q_wxyz": q,
        "omega_body_rad_s": w,
        "psi_ref_deg": np.degrees(psi_ref),
        "psi_dot_ref_rad_s": rec["psi_dot_ref_rad_s"],
        "psi_act_rad": psi_act,
        "psi_act_deg": np.degrees(psi_act),
        "psi_ref_wrapped_rad": np.mod(psi_ref, np.pi),
        "psi_act_wrapped_rad": np.mod(psi_act, np.pi),
        "psi_dot_act_rad_s": -w[:, 1],
        "psi_error_rad": dpsi,
        "err_rad": err,
        "err_deg": np.degrees(err),
        "T_act_y_Nm": T_act[:, 1],
        "torque_pitch_Nm": T_act[:, 1],  # video overlay (unit suffix it knows)
        "T_ref_norm_Nm": np.linalg.norm(T_ref, axis=1),
        "T_act_norm_Nm": np.linalg.norm(T_act, axis=1),
        "r_world_m": r_w,
        "ground_world_m": R_g,
        "plate_normal_world": R[:, :, 2],
    }
    ref = reference_products(plate) if ref is None else ref
    windows = pass_windows(plate, float(t[-1]))
    over_cap = sum(
        1 for _, _, a, b in windows if np.any((series["T_ref_norm_Nm"] > cap * (1 + 1e-9)) & (t >= a) & (t <= b))
    )
    sat_passes = sum(1 for _, _, a, b in windows if np.any(sat & (t >= a) & (t <= b)))
    dtw = _dt_weights(t)
    summary: dict[str, Any] = {
        **_run_summary(result, plate),
        "rate_term": plate.cfg.control.rate_term,
        "feedforward": plate.cfg.control.feedforward,
        "saturation": plate.cfg.control.saturation_mode,
        "omega_n_rad_s": plate.cfg.control.omega_n_rad_s,
        "areal_density_kg_m2": plate.cfg.plate.areal_density_kg_m2,
        "mass_kg": plate.mass_kg,
        "inertia_kgm2": plate.inertia.tolist(),
        "cap_Nm": cap,
        "orbit_period_s": o.period_s,
        "orbit_radius_m": o.r_m,
        "mean_motion_rad_s": o.n_rad_s,
        "t_mid_s": o.t_mid_s,
        "run_length_nominal_s": plate.cfg.orbit.n_orbits * o.period_s,
        "t_err_above_1deg_s": first_time(t, err > 1 * DEG),
        "t_err_above_5deg_s": first_time(t, err > 5 * DEG),
        "time_err_above_5deg_s": float(np.sum(dtw[err > 5 * DEG])),
        "err_max_rad": float(err.max()),
        "err_rms_rad": float(np.sqrt(np.mean(err**2))),
        "sat_fraction": float(np.mean(sat)),
        "passes_over_cap": int(over_cap),
        "torque_ff_peak_Nm": float(ref["torque_ff"].max()),
        "torque_ff_peak_sigma100_Nm": float(ref["torque_ff_sigma100"].max()),
        "torque_ff_peak_sigma10_Nm": float(ref["torque_ff_sigma10"].max()),
        "passes_ff_over_cap": int(
            sum(
                1
                for _, _, a, b in pass_windows(plate, float(ref["t"][-1]))
                if np.any((ref["torque_ff"] > cap) & (ref["t"] >= a) & (ref["t"] <= b))
            )
        ),
        "psi_dot_peak_rad_s": float(np.max(np.abs(ref["psi_dot"]))),
        "psi_ddot_peak_rad_s2": float(np.max(np.abs(ref["psi_ddot"]))),
        "tracking_lost_first_s": first_time(t, np.abs(dpsi) > 5 * DEG),
        "passes_saturated": int(sat_passes),
        "psi_error_rms_deg": float(np.degrees(np.sqrt(np.mean(dpsi**2)))),
        "psi_error_max_deg": float(np.degrees(np.max(np.abs(dpsi)))),
        "T_ref_peak_Nm": float(series["T_ref_norm_Nm"].max()),
        "field_max_T": float(np.linalg.norm(ref["B"], axis=1).max()),
        "field_min_T": float(np.linalg.norm(ref["B"], axis=1).min()),
    }
    if "torque_gg_world_Nm" in rec:
        gg = np.linalg.norm(rec["torque_gg_world_Nm"], axis=1)
        series["torque_gg_norm_Nm"] = gg
        summary["torque_gg_max_Nm"] = float(gg.max())
        summary["torque_gg_max_over_cap"] = float(gg.max() / cap)
    # reference-only products over the nominal run (own time axis ``ref_t_s``); the pass table goes
    # to passes.json with the plots
    units = {
        "t": "s",
        "psi_c": "rad",
        "psi_wrapped": "rad",
        "psi_dot": "rad_s",
        "psi_ddot": "rad_s2",
        "beta_ref": "rad",
        "B": "T",
        "torque_ff_sigma100": "Nm",
        "torque_ff_sigma10": "Nm",
        "torque_ff": "Nm",
    }
    for key, unit in units.items():
        series[f"ref_{key}_{unit}"] = ref[key]
    return summary, series
