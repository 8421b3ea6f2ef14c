"""Post-processing of truss runs into summary figures and time series.

Every function takes the data it needs (the :class:`~magsail_mj.concepts.truss_magnetorquer.model.TrussModel`,
node positions ``pos`` (T, n, 3) [m] in the world frame — an array, or a
:class:`~magsail_mj.lattice.trajectory.NodeTrajectory` that reads the recorded qpos block by block —
the run's records, config values), never the scenario object. Body frame: the best-fit rotation
``R`` (body → world) of the lattice.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from magsail_mj.analysis.energy import strain_energy, structural_failure
from magsail_mj.analysis.flatness import surface_sd
from magsail_mj.concepts.truss_magnetorquer.surface_angle import cell_surface_angle, local_surface_angle
from magsail_mj.control.profiles import torque_profile
from magsail_mj.environment.frames import lvlh_frame
from magsail_mj.estimation.attitude import best_fit_rotation, body_rates, euler_zyx, particle_inertia
from magsail_mj.lattice.geometry import stiffness_matrix
from magsail_mj.lattice.trajectory import NodeTrajectory, as_trajectory
from magsail_mj.lattice.properties import cantilever_linear, loaded_nodes, strut_stiffness
from magsail_mj.concepts.truss_magnetorquer.config import ProfileConfig
from magsail_mj.concepts.truss_magnetorquer.model import TrussModel
from magsail_mj.concepts.truss_magnetorquer.twist import low_modes, twist_shares
from magsail_mj.sim import RunResult

__all__ = [
    "common_summary",
    "dashpot_matrix",
    "modal_damping_ratios",
    "modal_energies",
    "surface_twist_share",
    "modal_keys",
    "N_MODES_REPORTED",
    "surface_uvw",
    "dynamic_summary",
    "profile_response",
    "cantilever_summary",
    "lvlh_attitude",
    "rigid_response",
    "PROFILE_AXES",
    "dominant_period",
    "cell_angle_keys",
    "commanded_impulse_Nms",
    "delivered_impulse_keys",
    "strut_tilt_rad",
    "strut_tilt_keys",
    "placement_ratios",
]

PROFILE_AXES = {"x1": 0, "y1": 1, "z1": 2}
"""Body axis index of a ``profile.axis`` name."""


#: samples of a fine time grid held at once by :func:`rigid_response` (0.01 s over the run) and
#: :func:`commanded_impulse_Nms` (one per step): their grids grow with the run's duration, not its
#: records, so they are walked in blocks (8 arrays of 64 Ki samples: 4 MiB) and only the values at the
#: record times are kept
FINE_BLOCK = 1 << 16


def _at_record_times(
    t: np.ndarray,
    n: int,
    segment: Callable[[int, int], tuple[np.ndarray, tuple[np.ndarray, ...]]],
    *,
    block: int | None = None,
) -> tuple[np.ndarray, ...]:
    """Values at the times ``t`` of functions tabulated on a fine grid of ``n`` points, interpolated
    linearly (``np.interp``), with the grid walked in blocks of ``block`` intervals (default
    :data:`FINE_BLOCK`): ``segment(a, b)`` returns the grid times of points ``a … b`` (inclusive)
    and the functions' values there, and is called for consecutive blocks in order (so it may carry
    running sums). Each time is interpolated between the same two grid points as over the whole
    grid, so the values are bit-identical to it; memory is one block whatever ``n``."""
    block = FINE_BLOCK if block is None else int(block)
    t = np.asarray(t, dtype=float)
    order = np.argsort(t, kind="stable")
    ts = t[order]
    outs: list[np.ndarray] | None = None
    a = 0
    while True:
        b = min(a + block, n - 1)
        x, values = segment(a, b)
        if outs is None:
            outs = [np.empty(t.shape) for _ in values]
        lo = 0 if a == 0 else int(np.searchsorted(ts, x[0], side="left"))
        hi = ts.size if b == n - 1 else int(np.searchsorted(ts, x[-1], side="right"))
        for out, f in zip(outs, values):
            out[order[lo:hi]] = np.interp(ts[lo:hi], x, f)
        if b == n - 1:
            return tuple(outs)
        a = b


def rigid_response(
    kind: str, t: np.ndarray, *, tau_max: float, t_end: float, t_v: float | None, inertia: float, dt_fine: float = 0.01
) -> tuple[np.ndarray, np.ndarray]:
    """Rigid-body angle and rate about the torque axis: ω = ∫τ/I dt, φ = ∫ω dt (from rest).

    Integrated by the trapezoid rule on a ``dt_fine`` grid (exact for the piecewise-constant
    bang-bang profile up to the breakpoints' grid alignment) and sampled at ``t``. The grid spans
    the run (``max(t) / dt_fine`` points): it is walked in blocks of :data:`FINE_BLOCK` points
    (:func:`_at_record_times`), so memory does not grow with the duration.
    """
    t = np.asarray(t, dtype=float)
    n = math.ceil((float(np.max(t)) + dt_fine) / dt_fine)  # len(np.arange(0.0, max(t) + dt_fine, dt_fine))
    carry = [0.0, 0.0]  # ω and φ at the block's first point

    def segment(a: int, b: int) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        tf = np.arange(a, b + 1) * dt_fine  # = np.arange(0.0, …, dt_fine)[a : b + 1], bit for bit
        y = np.asarray(torque_profile(kind, tf, tau_max=tau_max, t_end=t_end, t_v=t_v), dtype=float) / inertia
        d = np.diff(tf)
        w = np.cumsum(np.concatenate([[carry[0]], d * (y[1:] + y[:-1]) / 2.0]))
        phi = np.cumsum(np.concatenate([[carry[1]], d * (w[1:] + w[:-1]) / 2.0]))
        carry[:] = [w[-1], phi[-1]]
        return tf, (phi, w)

    phi, w = _at_record_times(t, n, segment)
    return phi, w


def dominant_period(t: np.ndarray, x: np.ndarray) -> float:
    """Period [s] of the largest non-zero-frequency FFT peak of ``x`` (uniform ``t``), linear
    trend removed; NaN for fewer than 8 samples or a constant signal."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.size < 8 or not np.all(np.isfinite(x)):
        return float("nan")
    y = x - np.polyval(np.polyfit(t, x, 1), t)
    spec = np.abs(np.fft.rfft(y * np.hanning(y.size)))
    f = np.fft.rfftfreq(y.size, d=float(t[1] - t[0]))
    if spec.size < 3 or not spec[1:].max() > 0:
        return float("nan")
    k = 1 + int(np.argmax(spec[1:]))
    return float(1.0 / f[k])


N_MODES_REPORTED = 5
"""Elastic modes in the modal summary keys (``modal_*_first5``, ``modal_energy_at_max_sd_J``)."""


def dashpot_matrix(nodes: np.ndarray, struts: np.ndarray, gamma: float | np.ndarray):
    """(3n, 3n) sparse damping matrix ``C`` of axial strut dashpots ``γ_s (ṙ·ê) ê`` linearised
    about ``nodes``: the stiffness-matrix assembly with ``γ`` in place of ``k`` [N s/m]."""
    g = np.broadcast_to(np.asarray(gamma, dtype=float), (np.asarray(struts).shape[0],))
    return stiffness_matrix(np.asarray(nodes, dtype=float), np.asarray(struts), g)


def modal_damping_ratios(omega: np.ndarray, phi: np.ndarray, C) -> np.ndarray:
    """ζ_n = φ_nᵀ C φ_n / (2 ω_n) of mass-normalised modes (``phi`` (3n, K), ``omega`` (K,) > 0
    [rad/s]) under the damping matrix ``C`` (3n × 3n, dense or sparse) [N s/m]: the damping ratio
    each mode has when the off-diagonal modal damping is neglected (exact for proportional ``C``)."""
    phi = np.asarray(phi, dtype=float)
    c_nn = np.einsum("ij,ij->j", phi, np.asarray(C @ phi))
    return c_nn / (2.0 * np.asarray(omega, dtype=float))


def modal_energies(
    nodes: np.ndarray, x: np.ndarray, masses: np.ndarray, omega: np.ndarray, phi: np.ndarray
) -> np.ndarray:
    """Strain energy ``½ ω_n² q_n²`` [J] of each mass-normalised mode in the shape ``x`` (n, 3) [m].

    The deformation is taken in the best-fit body frame (``x ≈ R p + d``):
    ``δ_i = Rᵀ (x_i − d) − p_i``, and ``q_n = φ_nᵀ M δ`` (``M`` = diag of ``masses`` [kg]). For a
    small deformation the energies of all modes add up to the lattice's strain energy.
    """
    R, d = best_fit_rotation(nodes, x)
    delta = ((np.asarray(x) - d) @ R - nodes).ravel()
    q = (np.repeat(np.asarray(masses, dtype=float), 3) * delta) @ phi
    return 0.5 * np.asarray(omega) ** 2 * q**2


def surface_twist_share(uvw: np.ndarray) -> float:
    """Share of the top layer's out-of-plane mean square (σ_SD²) in the twist saddle ``u v``.

    ``uvw`` (N², 3): the nodes in the average-plane frame (``u, v`` in plane along the projected
    body x1, y1 [m]; ``w`` the height, zero mean). With ``s = u v − mean(u v)``:
    ``share = (Σ w s)² / (Σ w² Σ s²)`` ∈ [0, 1] (1 for a pure twist, 0 for a shape orthogonal to it).
    """
    u, v, w = (np.asarray(uvw, dtype=float)[:, i] for i in range(3))
    s = u * v - np.mean(u * v)
    den = float(np.sum(w * w) * np.sum(s * s))
    return float(np.sum(w * s) ** 2 / den) if den > 0 else float("nan")


def modal_keys(tm: TrussModel, x_at_max: np.ndarray | None) -> dict[str, Any]:
    """Modal summary keys of a free lattice: frequencies [rad/s] and damping ratios (the strut
    dashpots ``γ`` of the run) of the first five elastic modes, their twist shares and, with the
    node positions ``x_at_max`` (n, 3) at the time of maximum σ_SD, their strain energies [J]."""
    lat = tm.lattice
    modes = low_modes(lat.nodes, lat.struts, tm.k, tm.masses, n_elastic=N_MODES_REPORTED)
    omega, phi = modes.elastic(N_MODES_REPORTED)
    zeta = modal_damping_ratios(omega, phi, dashpot_matrix(lat.nodes, lat.struts, tm.gamma))
    out: dict[str, Any] = {
        "modal_omega_first5_rad_s": omega.tolist(),
        "modal_damping_ratio_first5": zeta.tolist(),
        "modal_twist_share_first5": twist_shares(phi, lat.nodes, tm.masses).tolist(),
    }
    if x_at_max is not None:
        out["modal_energy_at_max_sd_J"] = modal_energies(lat.nodes, x_at_max, tm.masses, omega, phi).tolist()
    return out


def common_summary(
    tm: TrussModel, pos: NodeTrajectory | np.ndarray, result: RunResult, *, max_strain: float, zeta_strut: float
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The "all dynamic runs" keys: status, surface SD σ_SD of the top layer [m], strain energy
    Σ ½ k (|r_j − r_i| − L)² [J], largest strut strain, structural failure (``failed``: a recorded
    strain above ``max_strain`` or an inverted cube, or the run ended ``structure_failed`` or
    ``diverged``), damping constants, the modal keys (:func:`modal_keys`); series ``surface_sd_m``,
    ``strain_energy_J``, ``strut_strain_max``."""
    lat = tm.lattice
    t = result.records["t"]
    top = lat.top_nodes
    tets = lat.cube_tetrahedra()

    def per_record(x: np.ndarray) -> dict[str, np.ndarray]:
        check = structural_failure(
            x, lat.struts, lat.rest_length, tets=tets, reference=lat.nodes, strain_limit=max_strain
        )
        return {
            "sd": np.atleast_1d(surface_sd(x[:, top])),
            "energy": strain_energy(x, lat.struts, tm.k, lat.rest_length),
            "failed": check.failed,
            "max_abs_strain": check.max_abs_strain,
        }

    per = (
        as_trajectory(pos).map(per_record)
        if t.size
        else {k: np.zeros(0) for k in ("sd", "energy", "failed", "max_abs_strain")}
    )
    sd, energy = per["sd"], per["energy"]
    fail = per
    failed_idx = np.flatnonzero(fail["failed"])
    kmax = int(np.nanargmax(sd)) if sd.size else 0
    summary: dict[str, Any] = {
        "status": result.status,
        "status_message": result.message,
        "t_end_s": float(t[-1]) if t.size else 0.0,
        "surface_sd_max_m": float(np.nanmax(sd)) if sd.size else float("nan"),
        "t_surface_sd_max_s": float(t[kmax]) if t.size else float("nan"),
        "strain_energy_max_J": float(np.nanmax(energy)) if energy.size else float("nan"),
        "strut_strain_max": float(np.nanmax(fail["max_abs_strain"])) if t.size else float("nan"),
        "failed": bool(failed_idx.size > 0 or result.status in ("diverged", "structure_failed")),
        "t_failed_s": float(t[failed_idx[0]]) if failed_idx.size else float("nan"),
        "gamma_Ns_m": float(tm.gamma),
        "zeta_strut": float(zeta_strut),
        "stiffness_calibration_factor": float(tm.calibration_factor),
        "wall_time_s": float(result.wall_time_s),
    }
    summary.update(modal_keys(tm, as_trajectory(pos).at(kmax) if t.size else None))
    series = {"surface_sd_m": sd, "strain_energy_J": energy, "strut_strain_max": fail["max_abs_strain"]}
    return summary, series


def surface_uvw(top: np.ndarray, ang: Any) -> np.ndarray:
    """(N², 3) top-layer nodes ``top`` [m] in the average-plane frame of the surface angle ``ang``
    (:func:`~magsail_mj.concepts.truss_magnetorquer.surface_angle.local_surface_angle`): ``u, v``
    along its in-plane axes, ``w`` along its normal, from its centroid [m]."""
    rel = np.asarray(top) - ang.centroid
    return np.stack([rel @ ang.e_u, rel @ ang.e_v, rel @ ang.normal], axis=1)


def dynamic_summary(
    tm: TrussModel,
    pos: NodeTrajectory | np.ndarray,
    result: RunResult,
    *,
    omega0_body: np.ndarray,
    max_strain: float,
    zeta_strut: float,
    environment: Any = None,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary of a dynamic run (``dist_vs_central`` and ``free``).

    Attitude from the best-fit rotation ``R`` (ZYX Euler angles ψ, θ, φ [rad]), body rates ω
    [rad/s] by backward differences (``omega0_body`` at the first sample), the local surface angle
    at the time of maximum σ_SD and, with an ``environment``, the LVLH attitude
    (:func:`lvlh_attitude`).
    """
    summary, series = common_summary(tm, pos, result, max_strain=max_strain, zeta_strut=zeta_strut)
    lat = tm.lattice
    t = result.records["t"]
    if t.size < 2:
        return summary, series
    R = as_trajectory(pos).map(lambda x: best_fit_rotation(lat.nodes, x)[0])
    psi, theta, phi = euler_zyx(R, unwrap=True)
    dt_rec = float(t[1] - t[0])
    omega = body_rates(R, dt_rec, omega0=np.asarray(omega0_body))
    inertia = particle_inertia(lat.nodes, tm.masses)
    series.update(psi_rad=psi, theta_rad=theta, phi_rad=phi, omega_body_rad_s=omega, R_body_to_world=R)
    summary.update(
        {
            "rotation_x1_final_rad": float(phi[-1]),
            "phi_final_rad": float(phi[-1]),
            "off_axis_rotation_max_rad": float(max(np.max(np.abs(psi)), np.max(np.abs(theta)))),
            "psi_peak_abs_rad": float(np.max(np.abs(psi))),
            "theta_peak_abs_rad": float(np.max(np.abs(theta))),
            "omega1_peak_rad_s": float(np.max(np.abs(omega[:, 0]))),
            "I_kgm2": inertia.moments.tolist(),
        }
    )
    kmax = int(np.nanargmax(series["surface_sd_m"]))
    top = as_trajectory(pos).at(kmax)[lat.top_nodes]
    ang = local_surface_angle(top, R[kmax], nodes_per_side=lat.nodes_per_side)
    series.update(surface_angle_map_rad=ang.alpha, surface_angle_u_m=ang.u, surface_angle_v_m=ang.v)
    summary.update(
        {
            "twist_share_at_max_sd": surface_twist_share(surface_uvw(top, ang)),
            "surface_angle_median_rad": float(ang.median),
            "surface_angle_p95_rad": float(ang.p95),
            "surface_angle_max_rad": float(ang.max),
            "surface_angle_edge_max_rad": float(ang.edge_max),
            "surface_angle_spacing_m": float(ang.spacing_m),
            **cell_angle_keys(top, R[kmax], nodes_per_side=lat.nodes_per_side),
        }
    )
    if environment is not None:
        summary.update(environment.summary())
        series.update(lvlh_attitude(environment, t, R))
        summary["normal_to_orbit_normal_max_rad"] = float(np.max(series["normal_to_orbit_normal_rad"]))
    return summary, series


def profile_response(
    profile: ProfileConfig,
    t: np.ndarray,
    surface_sd_m: np.ndarray,
    *,
    inertia_kgm2: float,
    torque_cmd_body_Nm: np.ndarray,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The open-loop torque run against the rigid body: rigid angle and rate about the
    profile axis (:func:`rigid_response` with the moment ``inertia_kgm2`` [kg m²]) and σ_SD after the
    torque is off (t > 2 t_end / 3): mean, peak-to-peak [m] and linear slope [m/s]."""
    p = profile
    ang_rigid, rate_rigid = rigid_response(
        p.kind, t, tau_max=p.tau_max_Nm, t_end=p.t_end_s, t_v=p.t_v_s, inertia=inertia_kgm2
    )
    series = {"phi_rigid_rad": ang_rigid, "omega_rigid_rad_s": rate_rigid, "torque_cmd_x1_Nm": torque_cmd_body_Nm[:, 0]}
    summary: dict[str, Any] = {"phi_rigid_final_rad": float(ang_rigid[-1])}
    t_off = 2.0 * p.t_end_s / 3.0
    after = t > t_off
    if np.count_nonzero(after) >= 2:
        sd_after = surface_sd_m[after]
        fit = np.polyfit(t[after], sd_after, 1)
        residual = sd_after - np.polyval(fit, t[after])
        summary.update(
            {
                "surface_sd_after_off_mean_m": float(np.mean(sd_after)),
                "surface_sd_after_off_p2p_m": float(np.ptp(sd_after)),
                "surface_sd_after_off_slope_m_s": float(fit[0]),
                "surface_sd_after_off_osc_amplitude_m": float(np.sqrt(2.0 * np.mean(residual**2))),
                "surface_sd_after_off_period_s": dominant_period(t[after], sd_after),
            }
        )
    else:
        summary.update({k: float("nan") for k in AFTER_OFF_KEYS})
    return summary, series


AFTER_OFF_KEYS = (
    "surface_sd_after_off_mean_m",
    "surface_sd_after_off_p2p_m",
    "surface_sd_after_off_slope_m_s",
    "surface_sd_after_off_osc_amplitude_m",
    "surface_sd_after_off_period_s",
)
"""Keys of σ_SD after the torque is off (:func:`profile_response`)."""


def cell_angle_keys(top: np.ndarray, R_body: np.ndarray, *, nodes_per_side: int) -> dict[str, float]:
    """The artefact-free local surface angle statistics of the top layer ``top`` (N², 3) [m] at one
    time (:func:`~magsail_mj.concepts.truss_magnetorquer.surface_angle.cell_surface_angle`: each
    cell's own plane, no fit): ``surface_angle_cell_{median,p95,max,edge_max}_rad``."""
    cell = cell_surface_angle(top, R_body, nodes_per_side=nodes_per_side)
    return {
        "surface_angle_cell_median_rad": cell.median,
        "surface_angle_cell_p95_rad": cell.p95,
        "surface_angle_cell_max_rad": cell.max,
        "surface_angle_cell_edge_max_rad": cell.edge_max,
    }


def commanded_impulse_Nms(
    profile: ProfileConfig, t: np.ndarray, *, timestep_s: float, load_timing: str = "start"
) -> np.ndarray:
    """Commanded impulse about the profile axis ``I_cmd(t) = Σ_{t_k < t} τ(t_k + c δt) δt`` [N m s]
    at the record times ``t`` [s]: the runner holds the load's torque over each step
    ``[t_k, t_k + δt]`` (``δt = timestep_s``), evaluated at the step's start (``c = 0``,
    ``load_timing = "start"``: a left-rectangle sum) or its mid-point (``c = ½``, ``"midpoint"``:
    the mid-point rule), so this sum is what a rigid body receives exactly. The steps are walked
    in blocks of :data:`FINE_BLOCK` (memory does not grow with the number of steps)."""
    p = profile
    offset = {"start": 0.0, "midpoint": 0.5}[load_timing] * timestep_s
    n = int(round(float(np.max(t)) / timestep_s))
    carry = [0.0]

    def segment(a: int, b: int) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        tk = np.arange(a, b + 1) * timestep_s
        tau = np.asarray(
            torque_profile(p.kind, tk + offset, tau_max=p.tau_max_Nm, t_end=p.t_end_s, t_v=p.t_v_s), dtype=float
        )
        cum = np.cumsum(np.concatenate([[carry[0]], tau[:-1] * timestep_s]))
        carry[0] = cum[-1]
        return tk, (cum,)

    (impulse,) = _at_record_times(t, n + 1, segment)  # one point per step: walked in blocks
    return impulse


def delivered_impulse_keys(
    profile: ProfileConfig,
    t: np.ndarray,
    *,
    impulse_body_Nms: np.ndarray,
    impulse_cmd_Nms: np.ndarray,
    torque_ac_body_Nm: np.ndarray,
) -> dict[str, float]:
    """The impulse the strut couples delivered against the commanded one, about the profile axis
    ``a`` (``x1``, ``y1`` or ``z1``; the keys carry its name).

    ``impulse_body_Nms`` (T, 3): ``I(t) = Σ_k R_kᵀ τ_ac,k δt`` [N m s], the applied couples
    ``τ_ac = Σ_s (r_j − r_i) × F_j`` (world) in best-fit body axes ``R_k``, accumulated step by
    step; ``impulse_cmd_Nms`` (T,) the commanded ``I_cmd(t)`` (:func:`commanded_impulse_Nms`);
    ``torque_ac_body_Nm`` (T, 3) the couple of the last step before each record.

    Keys: ``impulse_<a>_{commanded,delivered}_Nms`` at the end of the run; the same at
    ``t_− = t_end / 3`` (the end of the first torque phase, or the run's end if earlier) with
    their ratio ``impulse_<a>_delivered_ratio_t_minus``; ``impulse_cross_peak_delivered_Nms`` the
    largest |impulse| about the two other body axes over the run; ``torque_ac_misalignment_max_rad``
    the largest angle between the applied couple and the commanded axis (± the axis, samples with
    a non-zero couple).
    """
    a = profile.axis
    ax = PROFILE_AXES[a]
    others = [k for k in range(3) if k != ax]
    t_minus = min(profile.t_end_s / 3.0, float(t[-1]))
    k_minus = int(np.searchsorted(t, t_minus + 1e-9, side="right") - 1)
    cmd_minus = float(impulse_cmd_Nms[k_minus])
    del_minus = float(impulse_body_Nms[k_minus, ax])
    tau = np.asarray(torque_ac_body_Nm, dtype=float)
    norm = np.linalg.norm(tau, axis=1)
    on = norm > 0
    cos = np.abs(tau[on, ax]) / norm[on]
    return {
        f"impulse_{a}_commanded_Nms": float(impulse_cmd_Nms[-1]),
        f"impulse_{a}_delivered_Nms": float(impulse_body_Nms[-1, ax]),
        f"impulse_{a}_commanded_t_minus_Nms": cmd_minus,
        f"impulse_{a}_delivered_t_minus_Nms": del_minus,
        f"impulse_{a}_delivered_ratio_t_minus": del_minus / cmd_minus if cmd_minus != 0 else float("nan"),
        "impulse_cross_peak_delivered_Nms": float(np.max(np.hypot(*impulse_body_Nms[:, others].T))),
        "torque_ac_misalignment_max_rad": float(np.max(np.arccos(np.clip(cos, -1.0, 1.0)))) if cos.size else 0.0,
    }


def strut_tilt_rad(
    pos: NodeTrajectory | np.ndarray, R_body_to_world: np.ndarray, *, nodes: np.ndarray, ends: np.ndarray
) -> np.ndarray:
    """(T,) the largest tilt [rad] over the struts ``ends`` (S, 2) (node indices) of each strut's
    axis in the best-fit body frame from its reference direction: with ``ê(t)`` the unit vector
    ``r_j − r_i`` (world) and ``ê₀`` that of the reference ``nodes`` (body), the tilt is
    ``arccos(ê₀ · R(t)ᵀ ê(t))``."""
    ends = np.asarray(ends, dtype=int)
    e_world = as_trajectory(pos).map(lambda x: x[:, ends[:, 1]] - x[:, ends[:, 0]])
    e_body = np.einsum("tji,tsj->tsi", np.asarray(R_body_to_world), e_world)
    e_body /= np.linalg.norm(e_body, axis=-1, keepdims=True)
    e0 = nodes[ends[:, 1]] - nodes[ends[:, 0]]
    e0 = e0 / np.linalg.norm(e0, axis=-1, keepdims=True)
    cos = np.clip(np.einsum("tsi,si->ts", e_body, e0), -1.0, 1.0)
    return np.max(np.arccos(cos), axis=1)


def strut_tilt_keys(t: np.ndarray, tilt_rad: np.ndarray) -> dict[str, float]:
    """``central_strut_tilt_{max,final}_rad`` and ``t_central_strut_tilt_max_s`` of the series
    ``tilt_rad`` (:func:`strut_tilt_rad`) at times ``t`` [s]."""
    k = int(np.nanargmax(tilt_rad))
    return {
        "central_strut_tilt_max_rad": float(tilt_rad[k]),
        "t_central_strut_tilt_max_s": float(t[k]),
        "central_strut_tilt_final_rad": float(tilt_rad[-1]),
    }


def placement_ratios(central: dict[str, Any], distributed: dict[str, Any]) -> dict[str, float]:
    """Central / distributed ratios of two ``dist_vs_central`` summaries of the same case and
    profile (the paper's Fig. 9 compares the local surface-angle maps of the two placements at
    each run's time of maximum σ_SD): the median local surface angle (the fitted map and the
    cell angles) and the maximum σ_SD. A failed run gives NaN (a crushed structure is not a
    ratio)."""
    keys = {
        "surface_angle_median_ratio": "surface_angle_median_rad",
        "surface_angle_cell_median_ratio": "surface_angle_cell_median_rad",
        "surface_sd_max_ratio": "surface_sd_max_m",
    }
    failed = bool(central.get("failed")) or bool(distributed.get("failed"))
    out = {}
    for name, key in keys.items():
        c, d = central.get(key, float("nan")), distributed.get(key, float("nan"))
        ok = not failed and d is not None and c is not None and d != 0
        out[f"{name}_central_to_distributed"] = float(c) / float(d) if ok else float("nan")
    return out


def lvlh_attitude(environment, t: np.ndarray, R: np.ndarray) -> dict[str, np.ndarray]:
    """Attitude relative to the reference orbit's LVLH frame (x̂ = r̂, ẑ = orbit normal ĥ).

    ``R_lvlh = L R`` with ``L`` the ECI → LVLH rotation; its ZYX angles (yaw ψ about ĥ, pitch,
    roll), and the angle between the plate normal (body z1) and ĥ.
    """
    samples = environment.sample_many(t)
    L = lvlh_frame(samples["r_ref_eci"], samples["v_ref_eci"])
    R_lvlh = L @ R
    yaw, pitch, roll = euler_zyx(R_lvlh, unwrap=True)
    cos_n = np.clip(np.einsum("ti,ti->t", R[:, :, 2], L[:, 2, :]), -1.0, 1.0)
    return {
        "lvlh_yaw_rad": yaw,
        "lvlh_pitch_rad": pitch,
        "lvlh_roll_rad": roll,
        "normal_to_orbit_normal_rad": np.arccos(cos_n),
        "r_ref_eci_m": samples["r_ref_eci"],
    }


def cantilever_summary(
    tm: TrussModel,
    pos: NodeTrajectory | np.ndarray,
    result: RunResult,
    *,
    load_N: float,
    EI_Nm2: float,
    calibration: str,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Cantilever check: linear solve (formula and calibrated) vs the MuJoCo settle.

    Tip load ``load_N`` [N] on the free edge, target ``EI_Nm2`` [N m²]; the beam deflection is
    δ = P L³ / (3 EI) and the effective stiffness EI_eff = P L³ / (3 δ).
    """
    lat = tm.lattice
    P = load_N
    EI = EI_Nm2
    k_formula = tm.k / tm.calibration_factor
    formula = cantilever_linear(lat, k_formula, load_N=P)
    used = cantilever_linear(lat, tm.k, load_N=P)
    # The calibrated spring constants exactly as the reproduction runs get them (factor from the
    # cached unit-size solve of ``calibration_factor``), so this checks that the factor carries
    # over to this d and EI; scaling k_formula by EI/EI_eff of this very solve would give 1 by
    # construction and test nothing.
    k_calibrated, _ = strut_stiffness(lat, EI_Nm2=EI, calibration="cantilever")
    calibrated = cantilever_linear(lat, k_calibrated, load_N=P)
    t = result.records["t"]
    tip = loaded_nodes(lat)
    tip_z = as_trajectory(pos).map(lambda x: -np.mean(x[:, tip, 2] - lat.nodes[tip, 2], axis=1))
    speed = np.abs(np.gradient(tip_z, t)) if t.size > 2 else np.array([np.nan])
    delta_mj = float(tip_z[-1])
    summary = {
        "status": result.status,
        "status_message": result.message,
        "EI_target_Nm2": EI,
        "EI_eff_formula_Nm2": formula.EI_eff_Nm2,
        "EI_ratio_formula": formula.EI_eff_Nm2 / EI,
        "stiffness_calibration": calibration,
        "stiffness_calibration_factor": EI / formula.EI_eff_Nm2,
        "EI_ratio_calibrated": calibrated.EI_eff_Nm2 / EI,
        "beam_deflection_m": P * lat.side_m**3 / (3 * EI),
        "tip_deflection_linear_m": used.tip_deflection_m,
        "tip_deflection_mujoco_m": delta_mj,
        "EI_eff_mujoco_Nm2": P * lat.side_m**3 / (3 * delta_mj) if delta_mj > 0 else float("nan"),
        "EI_ratio_mujoco": P * lat.side_m**3 / (3 * delta_mj) / EI if delta_mj > 0 else float("nan"),
        "linear_vs_mujoco_rel_diff": abs(delta_mj - used.tip_deflection_m) / used.tip_deflection_m,
        "tip_speed_final_m_s": float(speed[-1]),
        "settled": bool(speed[-1] < 1e-6 * max(delta_mj, 1e-300)),
        "tip_deflection_over_side": delta_mj / lat.side_m,
        "wall_time_s": result.wall_time_s,
    }
    return summary, {"tip_deflection_m": tip_z}
