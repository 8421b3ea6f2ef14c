r"""Orbital rod-array scenarios of the truss concept: ``detumble`` and ``slew``.

Robb et al. 2022a, Sec. 4.2–4.3; where the paper is ambiguous the choice is named where it is made. The tasks are
:class:`magsail_mj.concepts.truss_magnetorquer.tasks.DetumbleTask` and
:class:`~magsail_mj.concepts.truss_magnetorquer.tasks.SlewTask`; this module supplies them, from plain data
(config tables, the :class:`~magsail_mj.concepts.truss_magnetorquer.model.TrussModel`, records), never the
task object:

* the **rod load** (:func:`make_rod_load`, Robb et al. 2022a, Table 2) and the **controller**
  (:func:`rod_controller`: B-dot or quaternion feedback with gravity-gradient
  compensation; both feed the rod-count allocation (Eqs. 11–13) and the Lloyd selection,
  every ``control.period_s``, default every step);
* the **probes** recorded every ``sim.record_every`` steps (:func:`orbital_probes`);
* the **post-processing** into ``summary.json`` keys and time series (:func:`orbital_summary`,
  then :func:`detumble_keys` or :func:`slew_keys`) and the **plots** (:func:`orbital_plots`).

Frames: the world is the orbit-following frame (axes = ECI); ``R`` is the best-fit body → world
rotation of the controller, body components are ``Rᵀ v``. Units SI; angles in radians in
series and keys unless the key ends in ``_deg``.

Torques recorded (body components, N m):

* ``torque_ref_body_Nm`` — the controller's reference ``T_ref``;
* ``torque_alloc_body_Nm`` — what the allocation promises, ``N1 τ1 + N2 τ2`` (Robb et al. 2022a, Eqs. 11–13);
* ``torque_ac_body_Nm`` — the rods' actual torque ``T_ac = Σ_r m_r × B`` on the deformed struts
 ;
* ``torque_gg_body_Nm`` — the actual gravity-gradient torque of the particles,
  ``T_gg = Σ_i (x_i − x_c) × m_i a_tidal(x_i)`` (zero when the tidal load is off);
* ``torque_gg_rigid_body_Nm`` — the rigid estimate of Eq. 14, ``3μ/r⁵ r_b × 𝓘 r_b`` with the
  Eq. 21 inertia.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps

from magsail_mj.concepts.truss_magnetorquer.surface_angle import local_surface_angle
from magsail_mj.control.allocation import TorqueDistributor, allocation_mode_difference
from magsail_mj.control.bdot_flexible import BdotRodController
from magsail_mj.control.quaternion_feedback import QuaternionFeedbackRodController
from magsail_mj.control.rod_attitude import ProfileRodController, RodAttitudeController
from magsail_mj.estimation.attitude import (
    euler_zyx,
    matrix_from_quat,
    particle_inertia,
    quat_from_matrix,
    rotation_angle,
)
from magsail_mj.lattice.trajectory import NodeTrajectory, as_trajectory
from magsail_mj.loads.magnetorquer_rods import MagnetorquerRodLoad
from magsail_mj.loads.tidal import TidalGravityLoad
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.quaternion import error_quaternion, quat_conj, quat_mul
from magsail_mj.concepts.truss_magnetorquer.config import (
    ActuatorsConfig,
    ManeuverConfig,
    ProfileConfig,
    TrussConfig,
    TrussControlConfig,
)
from magsail_mj.concepts.truss_magnetorquer.force_pair import VariantPairRodLoad
from magsail_mj.concepts.truss_magnetorquer.metrics import (
    PROFILE_AXES,
    cell_angle_keys,
    common_summary,
    dominant_period,
    lvlh_attitude,
    surface_twist_share,
    surface_uvw,
)
from magsail_mj.concepts.truss_magnetorquer.model import TrussModel
from magsail_mj.concepts.truss_magnetorquer.mpc import FieldForecast, MagneticMpcController, MpcWeights, RigidPlant
from magsail_mj.sim import RunResult
from magsail_mj.vec3 import cross3, moment_sum

__all__ = [
    "RATE_THRESHOLD_RAD_S",
    "make_rod_load",
    "controller_inertia",
    "make_distributor",
    "rod_controller",
    "environment_forecast",
    "orbital_probes",
    "orbital_summary",
    "detumble_keys",
    "slew_keys",
    "saturation_phases",
    "orbital_plots",
    "orbital_manifest",
    "first_time_below",
    "stay_time_below",
    "true_intervals",
    "dominant_period",
    "slew_axis_angle",
    "tumbled",
]

RATE_THRESHOLD_RAD_S = 1e-3
"""Detumble threshold on every body-rate component."""
TUMBLE_ERROR_RAD = math.radians(45.0)
TUMBLE_CAPTURE_RAD = math.radians(10.0)
TUMBLE_RATE_RAD_S = 5e-3
"""Tumbling: the error exceeds 45° after having come within 10°, or |ω| > 5e-3 rad/s."""
LOW_AUTHORITY_RATIO = 0.1
"""Low authority: |T_ac| below 10 % of |T_ref| while |T_ref| exceeds the threshold."""


# =========================================================================== building blocks


def make_rod_load(actuators: ActuatorsConfig, tm: TrussModel) -> VariantPairRodLoad:
    """Rods in all top-layer x1/y1 struts, dipole from the Table 2 basis, field from
    ``state.env.B_eci`` (the field at the reference point, applied uniformly), force pair
    ``actuators.force_pair`` (:mod:`~magsail_mj.concepts.truss_magnetorquer.force_pair`)."""
    a = actuators
    return VariantPairRodLoad.from_variant(
        tm.lattice,
        kappa_Am2_kg=a.kappa_Am2_kg,
        rod_mass_kg=a.rod_mass_kg,
        basis=a.rod_dipole_basis,
        force_pair=a.force_pair,
    )


def controller_inertia(control: TrussControlConfig | None, tm: TrussModel) -> np.ndarray:
    """(3, 3) inertia of the gravity-gradient compensation [kg m²]: Eq. 21 of the undeformed
    particle set (Robb et al. 2022a, Eq. 21), or ``diag(control.gg_comp_inertia_kgm2)`` (as-printed variant)."""
    if control is not None and control.gg_comp_inertia_kgm2 is not None:
        return np.diag(np.asarray(control.gg_comp_inertia_kgm2, dtype=float))
    return particle_inertia(tm.lattice.nodes, tm.masses).tensor


def lloyd_seed(control: TrussControlConfig, sim_seed: int) -> int:
    """Seed of the Lloyd selection: ``control.lloyd.seed``, else ``sim.seed``."""
    return control.lloyd.seed if control.lloyd.seed is not None else sim_seed


def make_distributor(control: TrussControlConfig, rod_load: MagnetorquerRodLoad, *, sim_seed: int) -> TorqueDistributor:
    """Allocation (Eqs. 11–13) + Lloyd selection (seed :func:`lloyd_seed`)."""
    c = control
    return TorqueDistributor.for_rods(
        rod_load.rods,
        m_rod_Am2=rod_load.m_rod_Am2,
        mode=c.allocation,
        seed=lloyd_seed(c, sim_seed),
        tol_rel=c.lloyd.tol_rel,
        max_iter=c.lloyd.max_iter,
        cache_dir=c.cache_dir or None,
        symmetry=c.lloyd.symmetry,
    )


def rod_controller(
    cfg: TrussConfig, tm: TrussModel, rod_load: MagnetorquerRodLoad, *, mu_m3_s2: float, environment: Any = None
) -> RodAttitudeController:
    """The ``[control]`` law (``control.kind``: B-dot, quaternion feedback, the receding-horizon
    dipole plan or the open-loop ``[profile]``) feeding the rod allocation, sampled every
    ``control.period_s`` (default: every step); ``mu_m3_s2`` [m³/s²] is the gravitational parameter
    of the gravity-gradient compensation; ``environment`` (an
    :class:`~magsail_mj.environment.environment.Environment`) gives ``"mpc"`` its field forecast."""
    c = cfg.control
    common = dict(
        reference_nodes=tm.lattice.nodes,
        masses=tm.masses,
        distributor=make_distributor(c, rod_load, sim_seed=cfg.sim.seed),
        period_s=c.period_s if c.period_s is not None else cfg.sim.timestep_s,
        omega0_body=cfg.initial.omega0_rad_s,
        rate_method=c.rate_method,
    )
    if c.kind == "mpc":
        if environment is None:
            raise ValueError("environment: control.kind = 'mpc' needs the environment for its field forecast")
        return _mpc(cfg, tm, mu_m3_s2, common, rod_load, environment)
    return _CONTROL_LAWS[c.kind](cfg, tm, mu_m3_s2, common)


def environment_forecast(environment: Any, *, duration_s: float, step_s: float) -> FieldForecast:
    """The field and position forecast of ``environment`` (``sample_many``) on a grid of ``step_s``
    over ``[0, duration_s]``, interpolated linearly and held constant beyond its ends."""
    t_grid = np.arange(0.0, duration_s + step_s, step_s)
    env = environment.sample_many(t_grid)
    B, r = np.asarray(env["B_eci"], dtype=float), np.asarray(env["r_ref_eci"], dtype=float)

    def forecast(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.clip(np.asarray(t, dtype=float), t_grid[0], t_grid[-1]) / step_s
        k = np.minimum(x.astype(np.int64), len(t_grid) - 2)
        f = (x - k)[..., None]
        return (1 - f) * B[k] + f * B[k + 1], (1 - f) * r[k] + f * r[k + 1]

    return forecast


def _mpc(
    cfg: TrussConfig,
    tm: TrussModel,
    mu_m3_s2: float,
    common: dict[str, Any],
    rod_load: MagnetorquerRodLoad,
    environment: Any,
) -> RodAttitudeController:
    p = cfg.control.mpc
    M = np.asarray(rod_load.m_rod_Am2, dtype=float) * np.asarray(rod_load.rods.n_per_family, dtype=float)
    plant = RigidPlant(
        inertia_kgm2=particle_inertia(tm.lattice.nodes, tm.masses).tensor,
        max_dipole_Am2=M,
        mu_m3_s2=mu_m3_s2,
        forecast=environment_forecast(environment, duration_s=cfg.sim.duration_s, step_s=p.forecast_step_s),
        gravity_gradient=cfg.gravity.tidal,
    )
    weights = MpcWeights(
        horizon_s=p.horizon_s,
        step_s=p.step_s,
        substeps=p.substeps,
        rate_weight_s=p.rate_weight_s,
        terminal_weight=p.terminal_weight,
        effort_weight=p.effort_weight,
        step_weight=p.step_weight,
        iterations=p.iterations,
    )
    return MagneticMpcController(
        q_ref_wxyz=np.asarray(cfg.maneuver.q_ref_wxyz, dtype=float),
        plant=plant,
        weights=weights,
        replan_s=p.replan_s if p.replan_s is not None else p.step_s,
        **common,
    )


def _bdot(cfg: TrussConfig, tm: TrussModel, mu_m3_s2: float, common: dict[str, Any]) -> RodAttitudeController:
    return BdotRodController(k_Nms_T2=cfg.control.k_bdot_Nms_T2, **common)


def _quat_pd(cfg: TrussConfig, tm: TrussModel, mu_m3_s2: float, common: dict[str, Any]) -> RodAttitudeController:
    c = cfg.control
    q_ref = cfg.maneuver.q_ref_wxyz if cfg.maneuver.q_ref_wxyz is not None else cfg.q0_wxyz
    return QuaternionFeedbackRodController(
        q_ref_wxyz=q_ref,
        inertia_kgm2=controller_inertia(c, tm),
        Pq_Nm=c.Pq_Nm,
        Pw_Nms=c.Pw_Nms,
        gg_comp=c.gg_comp,
        mu=mu_m3_s2,
        **common,
    )


def _open_loop(cfg: TrussConfig, tm: TrussModel, mu_m3_s2: float, common: dict[str, Any]) -> RodAttitudeController:
    p: ProfileConfig = cfg.profile
    return ProfileRodController(
        kind=p.kind, tau_max_Nm=p.tau_max_Nm, t_end_s=p.t_end_s, t_v_s=p.t_v_s, axis=PROFILE_AXES[p.axis], **common
    )


_CONTROL_LAWS = {"bdot": _bdot, "quat_pd": _quat_pd, "open_loop": _open_loop}
"""``control.kind`` → controller factory (with ``"mpc"``, built by :func:`_mpc`, the kinds the
config schema allows)."""


def orbital_probes(
    tm: TrussModel,
    rod: MagnetorquerRodLoad,
    tidal: TidalGravityLoad | None,
    *,
    ntendon: int,
    mu_m3_s2: float,
    q_err: bool,
) -> dict[str, Any]:
    """Probes of the orbital runs (recorded every ``sim.record_every`` steps; module docstring).

    All read the held command ``state.ctrl`` (a :class:`~magsail_mj.control.rod_attitude.RodCommand`)
    rather than the controller object, so they stay right after a resume from a checkpoint.
    ``tidal`` is the tidal gravity load (``None``: T_gg = 0); ``ntendon`` the model's tendon count;
    ``q_err``: record the quaternion-feedback error quaternion too (``control.kind = "quat_pd"``).
    """
    n_nodes = tm.lattice.n_nodes
    masses = tm.masses
    w_com = masses / masses.sum()
    n1 = rod.rods.n_per_family[0]
    inertia = particle_inertia(tm.lattice.nodes, masses).tensor
    mu = mu_m3_s2

    def counts(s, d):
        pol = s.ctrl.polarity
        return np.array(
            [
                np.count_nonzero(pol[:n1] > 0),
                np.count_nonzero(pol[:n1] < 0),
                np.count_nonzero(pol[n1:] > 0),
                np.count_nonzero(pol[n1:] < 0),
            ],
            dtype=np.int32,
        )

    def t_ac(s, d):
        return s.ctrl.R.T @ rod.torque_world(s)

    def t_gg(s, d):
        if tidal is None:
            return np.zeros(3)
        x = s.pos[1 : n_nodes + 1]
        F = masses[:, None] * tidal.accelerations(np.asarray(s.env.r_ref_eci, dtype=float), x)
        xc = w_com @ x
        return s.ctrl.R.T @ moment_sum(x - xc, F)

    def t_gg_rigid(s, d):
        r_b = s.ctrl.R.T @ (np.asarray(s.env.r_ref_eci, dtype=float) + s.ctrl.com_world)
        r2 = float(r_b @ r_b)
        return 3.0 * mu / (r2 * r2 * math.sqrt(r2)) * cross3(r_b, inertia @ r_b)

    def activity(s, d):
        out = np.zeros(ntendon, dtype=np.int8)
        out[rod.rods.struts] = s.ctrl.polarity
        return out

    probes: dict[str, Any] = {
        "rod_counts": counts,
        "N_signed": lambda s, d: np.array([s.ctrl.N1, s.ctrl.N2], dtype=np.int32),
        "saturated": lambda s, d: np.array([s.ctrl.clipped1, s.ctrl.clipped2]),
        "control_counts": lambda s, d: s.ctrl.counts,
        "torque_ref_body_Nm": lambda s, d: s.ctrl.torque_ref_body,
        "torque_alloc_body_Nm": lambda s, d: s.ctrl.torque_alloc_body,
        "torque_ac_body_Nm": t_ac,
        "torque_gg_body_Nm": t_gg,
        "torque_gg_rigid_body_Nm": t_gg_rigid,
        "omega_est_body_rad_s": lambda s, d: s.ctrl.omega_body,
        "R_est": lambda s, d: s.ctrl.R,
        "B_eci_T": lambda s, d: s.env.B_eci,
        "B_body_T": lambda s, d: s.ctrl.B_body,
        "com_world_m": lambda s, d: s.ctrl.com_world,
        "r_ref_eci_m": lambda s, d: s.env.r_ref_eci,
        "strut_activity": activity,
    }
    if q_err:
        probes["q_err"] = lambda s, d: s.ctrl.extra["q_err"]
    return probes


def orbital_manifest(cfg: TrussConfig, tm: TrussModel, rod: MagnetorquerRodLoad) -> dict[str, Any]:
    """Manifest entries of the orbital runs: rods, control law, inertia used, Lloyd settings."""
    c, a = cfg.control, cfg.actuators
    return {
        "rods_per_family": list(rod.rods.n_per_family),
        "rod_dipole_Am2": list(rod.m_rod_Am2),
        "rod_dipole_basis": a.rod_dipole_basis,
        "rod_force_pair": a.force_pair,
        "stiffness_twist": cfg.stiffness.twist,
        "twist_diagonal_ratio": tm.twist_diagonal_ratio,
        "control_kind": c.kind,
        "control_period_s": c.period_s if c.period_s is not None else cfg.sim.timestep_s,
        "allocation_mode": c.allocation,
        "lloyd_seed": lloyd_seed(c, cfg.sim.seed),
        "lloyd_tol_rel": c.lloyd.tol_rel,
        "lloyd_symmetry": c.lloyd.symmetry,
        "lloyd_cache_dir": c.cache_dir,
        "gg_comp_inertia_kgm2": np.diag(controller_inertia(c, tm)).tolist(),
        "initial_q0_wxyz": list(cfg.q0_wxyz),
    }


# =========================================================================== metric helpers


def first_time_below(t: np.ndarray, x: np.ndarray, threshold: float) -> float:
    """First sample time with ``x ≤ threshold`` [s]; NaN when there is none."""
    idx = np.flatnonzero(np.asarray(x) <= threshold)
    return float(t[idx[0]]) if idx.size else float("nan")


def stay_time_below(t: np.ndarray, x: np.ndarray, threshold: float) -> float:
    """First sample time after which ``x`` stays ``≤ threshold`` to the end of the record [s].

    ``t[0]`` when it never exceeds the threshold; NaN when the last sample is above it.
    """
    above = np.flatnonzero(~(np.asarray(x) <= threshold))
    if not above.size:
        return float(t[0]) if len(t) else float("nan")
    k = above[-1] + 1
    return float(t[k]) if k < len(t) else float("nan")


def true_intervals(t: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(K, 2) start and end times [s] of the runs of ``True`` in ``mask`` (end = last true sample)."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return np.zeros((0, 2))
    d = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    start = np.flatnonzero(d == 1)
    end = np.flatnonzero(d == -1) - 1
    return np.stack([t[start], t[end]], axis=1)


def saturation_phases(t: np.ndarray, saturated: np.ndarray, *, split_s: float = 3600.0) -> dict[str, Any]:
    """The detumble's two saturation phases (the paper's "saturated through most of the first
    hour" and "a later burst"): the share of recorded samples before ``split_s`` [s] with either
    rod family saturated, and the longest run of saturated samples starting at or after
    ``split_s`` — its duration [s] (last − first saturated sample plus one record interval) and
    start [s]; ``None`` when there is none. ``saturated``: (T, families) booleans at times ``t``."""
    t = np.asarray(t, dtype=float)
    sat = np.asarray(saturated, dtype=bool).reshape(len(t), -1).any(axis=1)
    early = t < split_s
    dt_rec = float(t[1] - t[0]) if t.size > 1 else 0.0
    runs = true_intervals(t, sat)
    late = runs[runs[:, 0] >= split_s] if runs.size else runs
    out: dict[str, Any] = {
        "saturation_share_first_hour": float(sat[early].mean()) if early.any() else None,
        "saturation_burst_after_first_hour_s": None,
        "saturation_burst_start_s": None,
    }
    if late.size:
        k = int(np.argmax(late[:, 1] - late[:, 0]))
        out["saturation_burst_after_first_hour_s"] = float(late[k, 1] - late[k, 0] + dt_rec)
        out["saturation_burst_start_s"] = float(late[k, 0])
    return out


def slew_axis_angle(q_t: np.ndarray, q0: np.ndarray, q_ref: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    r"""Rotation angle about the slew axis.

    The slew takes ``q0`` to ``q_ref``: ``q_s = q0* ⊗ q_ref = [cos(Θ/2), sin(Θ/2) â]`` (``â`` in
    initial body components, ``Θ ∈ [0, π]``). For the attitude ``q_t`` the rotation from the
    start, ``q_rel = q0* ⊗ q_t`` (sign chosen with ``w ≥ 0``), is split into a twist about ``â``
    and a swing; the twist angle is ``2 atan2(â·q_rel,vec, q_rel,w)`` ∈ (−π, π].

    Returns ``(angle (T,), Θ, â)`` [rad].
    """
    qs = quat_mul(quat_conj(q0), q_ref)
    qs = -qs if qs[0] < 0 else qs
    sn = float(np.linalg.norm(qs[1:]))
    if not sn > 1e-12:
        return np.zeros(len(q_t)), 0.0, np.array([1.0, 0.0, 0.0])
    axis = qs[1:] / sn
    theta = 2.0 * math.atan2(sn, float(qs[0]))
    qr = quat_mul(quat_conj(q0), q_t)
    qr = np.where(qr[..., :1] < 0, -qr, qr)
    return 2.0 * np.arctan2(qr[..., 1:] @ axis, qr[..., 0]), theta, axis


def tumbled(err: np.ndarray, omega_norm: np.ndarray) -> bool:
    """Tumbling: the error exceeds 45° after having come within 10°, or |ω| > 5e-3 rad/s at any time."""
    err = np.asarray(err, dtype=float)
    if np.any(np.asarray(omega_norm) > TUMBLE_RATE_RAD_S):
        return True
    captured = np.flatnonzero(err <= TUMBLE_CAPTURE_RAD)
    return bool(captured.size and np.any(err[captured[0] :] > TUMBLE_ERROR_RAD))


def _trapz(y: np.ndarray, t: np.ndarray) -> float:
    return float(np.trapezoid(y, t)) if len(t) > 1 else 0.0


def _cumtrapz(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.zeros(len(t))
    if len(t) > 1:
        out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))
    return out


# =========================================================================== post-processing


def orbital_summary(
    cfg: TrussConfig,
    tm: TrussModel,
    pos: NodeTrajectory | np.ndarray,
    result: RunResult,
    *,
    environment: Any,
    rod: MagnetorquerRodLoad,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary keys and derived series common to ``detumble`` and ``slew`` runs.

    "all dynamic runs" keys (:func:`~magsail_mj.concepts.truss_magnetorquer.metrics.common_summary`), the
    local surface angle at the time of maximum σ_SD (``edge_angle_max_deg``), Euler angles of
    the best-fit rotation, |B| and the angle between B and the plate normal, saturation fractions,
    integrals of |T_ac|, |N1| + |N2| and of the total rod dipole Σ|m| = |N1| m₁ + |N2| m₂
    (``int_dipole_abs_Am2s`` [A m² s], over the run and the first hour), the paper-vs-exact
    allocation comparison over the recorded samples (Robb et al. 2022a, Eqs. 11–13, ``alloc_*``), and the orbit
    description (``environment.summary()``). ``pos``:
    node positions (T, n, 3) [m] (an array, or a :class:`~magsail_mj.lattice.trajectory.NodeTrajectory`
    reading the recorded qpos block by block); the kind's own keys come from :func:`detumble_keys` or
    :func:`slew_keys`.
    """
    summary, series = common_summary(tm, pos, result, max_strain=cfg.sim.max_strain, zeta_strut=cfg.damping.zeta_strut)
    lat, rec = tm.lattice, result.records
    t = rec["t"]
    summary.update(environment.summary())
    if t.size < 2:
        return summary, series
    R = rec["R_est"]
    omega = rec["omega_est_body_rad_s"]
    w_norm = np.linalg.norm(omega, axis=1)
    psi, theta, phi = euler_zyx(R, unwrap=True)
    R0 = matrix_from_quat(np.asarray(cfg.q0_wxyz, dtype=float))
    B = rec["B_eci_T"]
    B_norm = np.linalg.norm(B, axis=1)
    cosBn = np.einsum("ti,ti->t", B, R[:, :, 2]) / np.where(B_norm > 0, B_norm, 1.0)
    N = rec["N_signed"]
    T_ac, T_gg, T_ref = rec["torque_ac_body_Nm"], rec["torque_gg_body_Nm"], rec["torque_ref_body_Nm"]
    T_ac_norm = np.linalg.norm(T_ac, axis=1)
    N_abs = np.abs(N).sum(axis=1).astype(float)
    series.update(
        psi_rad=psi,
        theta_rad=theta,
        phi_rad=phi,
        omega_body_rad_s=omega,
        omega_norm_rad_s=w_norm,
        rotation_angle_rad=rotation_angle(R, relative_to=R0),
        B_norm_T=B_norm,
        B_normal_angle_rad=np.arccos(np.clip(cosBn, -1.0, 1.0)),
        N1=N[:, 0],
        N2=N[:, 1],
        int_T_ac_Nms=_cumtrapz(T_ac_norm, t),
        int_N_abs_s=_cumtrapz(N_abs, t),
        int_dipole_abs_Am2s=_cumtrapz(np.abs(N).astype(float) @ np.asarray(rod.m_rod_Am2, dtype=float), t),
    )
    series.update(lvlh_attitude(environment, t, R))

    # saturation: exact fractions from the controller's cumulative counters
    cnt = rec["control_counts"][-1].astype(float)
    n_ctrl = max(cnt[0], 1.0)
    sat = rec["saturated"].astype(bool)
    intervals = [
        np.column_stack([iv, np.full(len(iv), f + 1)]) for f in (0, 1) for iv in [true_intervals(t, sat[:, f])]
    ]
    series["saturation_intervals"] = np.concatenate(intervals) if intervals else np.zeros((0, 3))
    summary.update(saturation_phases(t, sat))

    # surface angle and shape at max SD
    kmax = int(np.nanargmax(series["surface_sd_m"]))
    at_max = as_trajectory(pos).at(kmax)[lat.top_nodes]
    ang = local_surface_angle(at_max, R[kmax], nodes_per_side=lat.nodes_per_side)
    uvw = surface_uvw(at_max, ang)
    series.update(
        surface_angle_map_rad=ang.alpha, surface_angle_u_m=ang.u, surface_angle_v_m=ang.v, shape_at_max_sd_uvw_m=uvw
    )
    inertia = particle_inertia(lat.nodes, tm.masses)
    B_body = rec["B_body_T"]
    m_rod = rod.m_rod_Am2
    n_max = rod.rods.n_per_family
    alloc = allocation_mode_difference(T_ref, B_body, m_rod_Am2=m_rod, n_max=n_max)
    summary.update(
        {
            "control_kind": cfg.control.kind,
            "control_samples": int(cnt[0]),
            "sat_fraction_family1": cnt[1] / n_ctrl,
            "sat_fraction_family2": cnt[2] / n_ctrl,
            "saturation_fraction": cnt[3] / n_ctrl,
            "n_saturation_intervals": int(len(series["saturation_intervals"])),
            "surface_angle_median_rad": float(ang.median),
            "surface_angle_p95_rad": float(ang.p95),
            "surface_angle_max_rad": float(ang.max),
            "surface_angle_edge_max_rad": float(ang.edge_max),
            "surface_angle_spacing_m": float(ang.spacing_m),
            "edge_angle_max_deg": math.degrees(float(ang.edge_max)),
            **cell_angle_keys(at_max, R[kmax], nodes_per_side=lat.nodes_per_side),
            "twist_share_at_max_sd": surface_twist_share(uvw),
            "surface_sd_period_s": dominant_period(t, series["surface_sd_m"]),
            "I_kgm2": inertia.moments.tolist(),
            "rod_dipole_Am2": list(m_rod),
            "int_T_ac_Nms": float(series["int_T_ac_Nms"][-1]),
            "int_T_ac_first_3600s_Nms": float(np.interp(min(3600.0, t[-1]), t, series["int_T_ac_Nms"])),
            "int_N_abs_s": float(series["int_N_abs_s"][-1]),
            "int_dipole_abs_Am2s": float(series["int_dipole_abs_Am2s"][-1]),
            "int_dipole_abs_first_3600s_Am2s": float(np.interp(min(3600.0, t[-1]), t, series["int_dipole_abs_Am2s"])),
            "T_ac_max_Nm": float(T_ac_norm.max()),
            "T_gg_max_Nm": float(np.linalg.norm(T_gg, axis=1).max()),
            "B_norm_min_T": float(B_norm.min()),
            "B_norm_max_T": float(B_norm.max()),
            **{f"alloc_{k}": v for k, v in alloc.items()},
        }
    )
    return summary, series


def detumble_keys(
    t: np.ndarray, omega: np.ndarray, *, inertia_kgm2: np.ndarray, omega0_body: np.ndarray
) -> dict[str, Any]:
    """Detumbling metrics of body rates ``omega`` (T, 3) [rad/s] at times ``t`` [s]: time all three rates
    fall / stay below 1e-3 rad/s, residual rates over the last 1800 s, and the initial angular
    momentum H0 = |I ω0| [N m s] (``inertia_kgm2`` (3, 3), ``omega0_body`` [rad/s])."""
    w_norm = np.linalg.norm(omega, axis=1)
    wmax = np.max(np.abs(omega), axis=1)
    thr = RATE_THRESHOLD_RAD_S
    last = t >= t[-1] - 1800.0
    w0 = np.asarray(omega0_body, dtype=float)
    stay = stay_time_below(t, wmax, thr)
    return {
        "rate_threshold_rad_s": thr,
        "t_rates_below_threshold_first_s": first_time_below(t, wmax, thr),
        "t_rates_below_threshold_stay_s": stay,
        "time_rates_below_1e-3_s": stay,
        "omega_rms_last_1800s_rad_s": float(np.sqrt(np.mean(w_norm[last] ** 2))),
        "omega_final_rad_s": omega[-1].tolist(),
        "omega_norm_max_rad_s": float(w_norm.max()),
        "H0_Nms": float(np.linalg.norm(inertia_kgm2 @ w0)),
    }


def slew_keys(
    rec: dict[str, np.ndarray],
    *,
    q0_wxyz: tuple[float, ...],
    maneuver: ManeuverConfig,
    low_authority_threshold_Nm: float,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Slew metrics of the records ``rec`` (best-fit rotation ``R_est``, estimated body rate,
    reference and actual rod torques): error thresholds and settling, overshoot about the slew axis
    from ``q0_wxyz`` to ``maneuver.q_ref_wxyz``, tumbling, low-authority time (|T_ac| below 10 % of
    |T_ref| while |T_ref| > ``low_authority_threshold_Nm`` [N m]). Returns ``(series, keys)``."""
    t = rec["t"]
    w_norm = np.linalg.norm(rec["omega_est_body_rad_s"], axis=1)
    T_ac_norm = np.linalg.norm(rec["torque_ac_body_Nm"], axis=1)
    T_ref = rec["torque_ref_body_Nm"]
    q0 = np.asarray(q0_wxyz, dtype=float)
    q0 /= np.linalg.norm(q0)
    q_ref = np.asarray(maneuver.q_ref_wxyz, dtype=float)
    q_ref /= np.linalg.norm(q_ref)
    q_t = quat_from_matrix(rec["R_est"])
    q_e = error_quaternion(q_ref, q_t)
    err = 2.0 * np.arctan2(np.linalg.norm(q_e[:, 1:], axis=1), q_e[:, 0])
    about, theta_s, axis = slew_axis_angle(q_t, q0, q_ref)
    d5, d2 = math.radians(5.0), math.radians(2.0)
    steps = np.arange(1800.0, t[-1] + 1e-9, 1800.0)
    thr = low_authority_threshold_Nm
    T_ref_norm = np.linalg.norm(T_ref, axis=1)
    low = (T_ref_norm > thr) & (T_ac_norm < LOW_AUTHORITY_RATIO * T_ref_norm)
    dt_rec = float(t[1] - t[0])
    overshoot = max(0.0, float(np.max(about)) - theta_s) if theta_s > 0 else float("nan")
    settle = stay_time_below(t, err, d5)
    keys = {
        "slew_angle_rad": theta_s,
        "slew_axis_body": axis.tolist(),
        "err_initial_rad": float(err[0]),
        "t_err_below_5deg_first_s": first_time_below(t, err, d5),
        "t_err_below_5deg_stay_s": settle,
        "t_err_below_2deg_first_s": first_time_below(t, err, d2),
        "t_err_below_2deg_stay_s": stay_time_below(t, err, d2),
        "settle_time_s": settle,
        "overshoot_rad": overshoot,
        "overshoot_deg": math.degrees(overshoot),
        "err_final_rad": float(err[-1]),
        "final_error_deg": math.degrees(float(err[-1])),
        "err_at_0p5h_steps_rad": [float(np.interp(s, t, err)) for s in steps],
        "tumbled": tumbled(err, w_norm),
        "omega_norm_max_rad_s": float(w_norm.max()),
        "low_authority_time_s": float(np.count_nonzero(low) * dt_rec),
        "low_authority_threshold_Nm": thr,
    }
    series = {"error_angle_rad": err, "error_angle_deg": np.degrees(err), "slew_axis_angle_rad": about}
    return series, keys


# =========================================================================== plots


def orbital_plots(
    run_dir: Path,
    records: dict[str, np.ndarray],
    series: dict[str, np.ndarray],
    *,
    title: str,
    nodes_per_side: int,
    side_m: float,
) -> list[Path]:
    """The detumbling/slew figures of a run (PNG, written atomically); returns their paths.

    ``body_rates.png`` (components, and |ω_i| on a log scale with the 1e-3 rad/s line),
    ``attitude.png`` (ZYX Euler angles, rotation angle from the start, error angle and the angle
    about the slew axis for slews), ``rod_counts.png`` (signed N1, N2 and the number of + / − rods
    per family), ``torques.png`` (T_ac solid and T_gg dashed, body components, as the paper's
    Fig. 23c, with T_ref dotted), ``field.png`` (|B| and the angle between B and the plate
    normal), ``surface_sd.png`` (σ_SD and strain energy), ``effort.png`` (cumulative ∫|T_ac| dt
    and ∫(|N1|+|N2|) dt), ``surface_angle_map.png`` and ``shape_at_max_sd.png`` (local surface
    angle and the top-layer shape at the time of maximum σ_SD, exaggerated to 10 % of ``side_m``).
    ``records``: the run's probe records; ``nodes_per_side``: of the lattice's top layer.
    """
    t = series["t"]
    if "omega_body_rad_s" not in series:
        return []
    rec = records
    th = t / 3600.0
    out: list[Path] = []
    comp = ("x1", "y1", "z1")
    colours = ("C0", "C1", "C2")

    fig, axs = new_figure(2, 1, figsize=(9, 7), sharex=True)
    w = series["omega_body_rad_s"]
    for i in range(3):
        axs[0].plot(th, w[:, i], color=colours[i], lw=0.8, label=f"ω{i + 1}")
        axs[1].semilogy(th, np.abs(w[:, i]), color=colours[i], lw=0.6, label=f"|ω{i + 1}|")
    axs[1].axhline(RATE_THRESHOLD_RAD_S, color="k", ls="--", lw=1, label="1e-3 rad/s")
    axs[0].set(ylabel="body rate [rad/s]", title=title + " — body rates (best fit, backward difference)")
    axs[1].set(xlabel="t [h]", ylabel="|ω_i| [rad/s]")
    axs[0].legend(ncol=3)
    axs[1].legend(ncol=4, fontsize=8)
    out.append(save_figure(fig, run_dir / "body_rates.png"))

    slew = "error_angle_rad" in series
    fig, axs = new_figure(3 if slew else 2, 1, figsize=(9, 9 if slew else 6.5), sharex=True)
    for key, label, c in (("psi_rad", "ψ (z)", "C0"), ("theta_rad", "θ (y)", "C1"), ("phi_rad", "φ (x)", "C2")):
        axs[0].plot(th, np.degrees(series[key]), color=c, label=label)
    axs[0].set(ylabel="ZYX Euler angles [deg]", title=title + " — attitude (body → ECI)")
    axs[0].legend(ncol=3)
    axs[1].plot(th, np.degrees(series["rotation_angle_rad"]), "k", label="rotation angle of R0ᵀR")
    if slew:
        axs[1].plot(th, np.degrees(series["slew_axis_angle_rad"]), "C3", label="angle about slew axis")
        axs[2].semilogy(th, np.maximum(series["error_angle_deg"], 1e-3), "C3", label="error angle 2 acos|q_e0|")
        for lvl in (5.0, 2.0):
            axs[2].axhline(lvl, color="k", ls=":", lw=1)
        axs[2].set(ylabel="error [deg]")
        axs[2].legend()
    axs[1].set(ylabel="angle [deg]")
    axs[1].legend()
    axs[-1].set_xlabel("t [h]")
    out.append(save_figure(fig, run_dir / "attitude.png"))

    fig, axs = new_figure(2, 1, figsize=(9, 6.5), sharex=True)
    axs[0].plot(th, series["N1"], "C0", lw=0.6, label="N1 (x1 rods)")
    axs[0].plot(th, series["N2"], "C1", lw=0.6, label="N2 (y1 rods)")
    axs[0].set(ylabel="signed active rods", title=title + " — active rods per family (sign = polarity)")
    axs[0].legend()
    cnt = rec["rod_counts"]
    for j, (lab, c, ls) in enumerate(
        (("x1 +", "C0", "-"), ("x1 −", "C0", ":"), ("y1 +", "C1", "-"), ("y1 −", "C1", ":"))
    ):
        axs[1].plot(th, cnt[:, j], color=c, ls=ls, lw=0.6, label=lab)
    axs[1].set(xlabel="t [h]", ylabel="rods on")
    axs[1].legend(ncol=4)
    out.append(save_figure(fig, run_dir / "rod_counts.png"))

    fig, ax = new_figure(figsize=(9, 4.5))
    T_ac, T_gg, T_ref = rec["torque_ac_body_Nm"], rec["torque_gg_body_Nm"], rec["torque_ref_body_Nm"]
    lim = 1.2 * max(float(np.max(np.abs(T_ac))), float(np.max(np.abs(T_gg))), 1e-6)
    for i in range(3):
        ax.plot(th, T_ac[:, i], color=colours[i], lw=0.6, label=f"T_ac {comp[i]}")
        ax.plot(th, T_gg[:, i], color=colours[i], ls="--", lw=1.0, label=f"T_gg {comp[i]}")
    if slew:
        for i in range(3):
            ax.plot(th, T_ref[:, i], color=colours[i], ls=":", lw=0.8, label=f"T_ref {comp[i]}")
    ax.set(
        xlabel="t [h]",
        ylabel="torque, body axes [N m]",
        ylim=(-lim, lim),
        title=title + " — rod (T_ac) and gravity-gradient (T_gg) torque",
    )
    ax.legend(ncol=3, fontsize=7)
    out.append(save_figure(fig, run_dir / "torques.png"))

    fig, axs = new_figure(2, 1, figsize=(9, 5.5), sharex=True)
    axs[0].plot(th, series["B_norm_T"] * 1e6)
    axs[0].set(ylabel="|B| [µT]", title=title + " — geomagnetic field at the centre of mass")
    axs[1].plot(th, np.degrees(series["B_normal_angle_rad"]))
    axs[1].set(xlabel="t [h]", ylabel="angle(B, plate normal) [deg]")
    out.append(save_figure(fig, run_dir / "field.png"))

    fig, axs = new_figure(2, 1, figsize=(9, 5.5), sharex=True)
    axs[0].plot(th, series["surface_sd_m"] * 1e3)
    axs[0].set(ylabel="surface SD [mm]", title=title + " — flatness and strain energy")
    axs[1].plot(th, series["strain_energy_J"])
    axs[1].set(xlabel="t [h]", ylabel="strain energy [J]")
    out.append(save_figure(fig, run_dir / "surface_sd.png"))

    fig, axs = new_figure(2, 1, figsize=(9, 5.5), sharex=True)
    axs[0].plot(th, series["int_T_ac_Nms"])
    axs[0].set(ylabel="∫|T_ac| dt [N m s]", title=title + " — cumulative control effort")
    axs[1].plot(th, series["int_N_abs_s"])
    axs[1].set(xlabel="t [h]", ylabel="∫(|N1|+|N2|) dt [rod s]")
    out.append(save_figure(fig, run_dir / "effort.png"))

    k = int(np.nanargmax(series["surface_sd_m"]))
    fig, ax = new_figure(figsize=(6.5, 5.5))
    im = ax.pcolormesh(
        series["surface_angle_u_m"],
        series["surface_angle_v_m"],
        np.degrees(series["surface_angle_map_rad"]),
        shading="auto",
        cmap="viridis",
    )
    fig.colorbar(im, ax=ax, label="local surface angle [deg]")
    ax.set(xlabel="u [m]", ylabel="v [m]", aspect="equal", title=f"local surface angle at max SD (t = {t[k]:.0f} s)")
    out.append(save_figure(fig, run_dir / "surface_angle_map.png"))

    uvw = series["shape_at_max_sd_uvw_m"]
    n = nodes_per_side
    fig, ax = new_figure(figsize=(8, 6), subplot_kw={"projection": "3d"})
    wmax = max(float(np.max(np.abs(uvw[:, 2]))), 1e-12)
    exag = 0.1 * side_m / wmax
    U, V, W = (uvw[:, i].reshape(n, n) for i in range(3))
    surf = ax.plot_surface(
        U,
        V,
        W * exag,
        facecolors=colormaps["PuOr_r"](0.5 + 0.5 * W / wmax),
        shade=False,
        rstride=1,
        cstride=1,
        linewidth=0.3,
        edgecolor="k",
    )
    del surf
    ax.set(
        xlabel="u [m]",
        ylabel="v [m]",
        zlabel=f"w × {exag:.3g} [m]",
        title=f"top layer at max SD (t = {t[k]:.0f} s), |w|max = {wmax * 1e3:.3g} mm, ×{exag:.3g}",
    )
    out.append(save_figure(fig, run_dir / "shape_at_max_sd.png"))
    return out
