r"""Probes and metrics of the current-loops runs.

Flexible runs record the node positions (every ``record_every`` steps), the kinetic energy and
the work ledger (Lorentz work and damping work, exact for forces held over a step). From them:

* strain energy ``U(t) = Σ ½ k (|r_j − r_i| − L)²``;
* best-fit rotation ``R_θ(t)`` (Kabsch, uniform masses) and its angle; body-frame displacement
  ``u = R_θᵀ(r − c) − (r₀ − c₀)``; thickness ``h = max z_b − min z_b``; rigid-fit residual
  ``ρ = √mean|u|²``; largest strut strain;
* modal amplitudes ``q_n = φ_nᵀ M u`` of the first elastic modes, normalised by their overall max;
* angle between the circuits' dipole axis (body) and the field;
* energy balance ``E_kin + U − W_Lorentz − W_damping`` relative to the largest ``|W_Lorentz|``;
* the rigid-body reference (:mod:`magsail_mj.concepts.current_loops.rigid_reference`) with the realised
  dipole, its rotation angle and the flexible run's largest deviation from it;
* classification (thresholds in ``[classification]``): *collapsed* if ρ_max > 0.1 D, or
  the largest strain > 0.5, or h_max > 5 w; *rigid_like* if ρ_max < 0.005 D and the rotation
  stays within 3° of the rigid reference; otherwise *flexible*. Beside it, the classification by
  shape alone (the same thresholds without the strain bound: does the plate look collapsed when a
  strut gives way?), the criteria that were met, and the fold angle: the largest rotation between
  the best rigid fits of the plate's two halves, over four dividing lines (:func:`fold_angle`).

Slews add the attitude error ``2 atan2(|q_e,xyz|, |q_e,w|)``, currents, saturation, commanded and achieved
dipole, magnetic and gravity-gradient torques about the centre of mass.

Shape of the response (the figures the papers' S4/S5 plots are read against):

* **stretch** along body ``x``/``y``: the change of the plate's in-plane extent,
  ``s_x(t) = (max x_b − min x_b)(t) − D_x`` [m] (``D_x`` the undeformed extent) (positive: stretched), its
  signed extremum, the sign of that extremum, and the **half-swing** = half the peak-to-peak of
  ``s`` over the late part of the run (``t ≥ t_0 + ½ (t_end − t_0)``, :data:`LATE_FRACTION`) with
  the mean it swings about (:func:`stretch_keys`);
* **strain-energy peaks**: the peaks of ``U(t)`` whose prominence is at least
  :data:`PEAK_PROMINENCE` of ``max U`` (a run that still rises at its end counts its last sample
  as a peak), their count and times, and ``t(max U)`` as a fraction of the run
  (:func:`strain_energy_peaks`);
* **saturation intervals** of a slew's current command (any axis clipped): count, start and end
  times, total saturated time, per-axis counts, and which interval holds ``max U``
  (:func:`saturation_keys`);
* **dominant modes** of a slew: the strain energy ``E_n = ½ ω_n² q_n²`` [J] of every elastic mode
  of the body-frame deformation (``q_n = φ_nᵀ M u``), its share ``E_n / Σ_m E_m`` at ``max U``
  and time-averaged (``Σ_t E_n / Σ_t Σ_m E_m``, weighting each record by its energy), and the
  :data:`N_DOMINANT` largest with their frequencies (:func:`modal_energy_profile`,
  :func:`dominant_modes`); the same over the last :data:`LAST_WINDOW_S` of the run
  (``t ≥ t_end − LAST_WINDOW_S``), and the share of the first :data:`N_FIRST_MODES` elastic modes
  in the total modal strain energy (:func:`modal_energy_summary`);
* **error swings** of a slew: the times and values of the extrema of the attitude error after it
  first comes within 5°, and the half-swing durations between them (:func:`error_swing_keys`).

Every function takes the data it needs (the :class:`~magsail_mj.concepts.current_loops.model.LoopsModel`,
node positions ``x`` (T, n, 3) [m], the records, config values), never the task object.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Iterable

import numpy as np

from scipy.signal import find_peaks

from magsail_mj.analysis.energy import strain_energy, strut_strain
from magsail_mj.lattice.modes import Modes
from magsail_mj.lattice.trajectory import NodeTrajectory, as_trajectory
from magsail_mj.concepts.current_loops.rigid_reference import rigid_dipole_attitude
from magsail_mj.estimation.attitude import BestFitRotation, euler_zyx, matrix_from_quat, rotation_angle
from magsail_mj.concepts.current_loops.lorentz import (
    CircuitSegments,
    LorentzLoad,
    lorentz_node_forces,
    self_field_max_T,
)
from magsail_mj.loads.tidal import GravityGradientTorqueLoad, TidalGravityLoad
from magsail_mj.concepts.current_loops.config import ClassificationConfig
from magsail_mj.concepts.current_loops.model import LoopsModel, WorkLedger
from magsail_mj.sim import RunResult
from magsail_mj.quaternion import quat_angle

__all__ = [
    "flexible_probes",
    "rigid_probes",
    "slew_probes",
    "flexible_torque_probe",
    "rigid_torque_probe",
    "base_summary",
    "sweep_metrics",
    "slew_metrics",
    "slew_structure",
    "classify",
    "classification_keys",
    "FoldAngle",
    "fold_angle",
    "fold_keys",
    "plate_halves",
    "first_time_below",
    "structural_series",
    "stretch_keys",
    "strain_energy_peaks",
    "saturation_intervals",
    "saturation_keys",
    "modal_strain_energies",
    "modal_energy_profile",
    "dominant_modes",
    "modal_energy_stats",
    "modal_energy_summary",
    "ModalEnergySummary",
    "first_modes_share_keys",
    "error_swing_keys",
    "shape_keys",
]

N_MODAL = 10
LATE_FRACTION = 0.5
"""The late part of a run for the stretch half-swing: ``t ≥ t_0 + LATE_FRACTION (t_end − t_0)``."""
PEAK_PROMINENCE = 0.2
"""A strain-energy peak counts when its prominence is at least this fraction of ``max U``."""
N_DOMINANT = 3
"""Dominant modes reported per slew."""
N_INTERVALS_LISTED = 50
"""Saturation intervals listed in a summary (the count and total cover all)."""
LAST_WINDOW_S = 2000.0
"""The closing window of a slew for its modal figures: ``t ≥ t_end − LAST_WINDOW_S`` [s]."""
N_FIRST_MODES = 10
"""The elastic modes 1 … N_FIRST_MODES whose share of the modal strain energy a slew reports."""
SWING_SETTLE_DEG = 5.0
"""The error swings are counted from the first time the attitude error comes within this [deg]."""
SWING_PROMINENCE_FRACTION = 0.02
"""An extremum of the attitude error counts when its prominence is at least this fraction of the
largest swing (``max − min`` of the error after it first comes within :data:`SWING_SETTLE_DEG`)."""
N_EXTREMA_LISTED = 100
"""Error extrema listed in a summary (the count and the mean half-swing cover all)."""

Probe = Callable[[Any, Any], np.ndarray]
Metrics = tuple[dict[str, Any], dict[str, np.ndarray]]


# =========================================================================== probes


def flexible_probes(node_bodies: np.ndarray, masses: np.ndarray, ledger: WorkLedger | None) -> dict[str, Probe]:
    """``qpos``, kinetic energy ½ Σ m_i |v_i|² [J] and, with a work ``ledger``, the work [J] of
    the loads it watches (up to the current positions)."""
    nb, m = node_bodies, masses
    out: dict[str, Probe] = {
        "qpos": lambda s, d: d.qpos,
        "kinetic_energy_J": lambda s, d: 0.5 * float(m @ np.einsum("ij,ij->i", s.vel[nb], s.vel[nb])),
    }
    if ledger is not None:
        out["work_J"] = lambda s, d: ledger.values(s.pos)
    return out


def rigid_probes() -> dict[str, Probe]:
    """``qpos`` and ``qvel`` of the rigid surrogate."""
    return {"qpos": lambda s, d: d.qpos, "qvel": lambda s, d: d.qvel}


def slew_probes(torque_probe: Probe) -> dict[str, Probe]:
    """The slew controller's held command (currents, saturation, attitude, rates, torque and dipole
    commands, field in body axes; neutral values before the first command) and the torques."""
    return {
        "currents_A": lambda s, d: s.ctrl.currents_A if s.ctrl is not None else np.zeros(3),
        "currents_axis_A": lambda s, d: s.ctrl.currents_axis_A if s.ctrl is not None else np.zeros(3),
        "saturated": lambda s, d: s.ctrl.saturated if s.ctrl is not None else np.zeros(3, bool),
        "q": lambda s, d: s.ctrl.q if s.ctrl is not None else np.array([1.0, 0, 0, 0]),
        "q_err": lambda s, d: s.ctrl.q_err if s.ctrl is not None else np.array([1.0, 0, 0, 0]),
        "omega_body_rad_s": lambda s, d: s.ctrl.omega_body if s.ctrl is not None else np.zeros(3),
        "torque_ref_body_Nm": lambda s, d: s.ctrl.torque_ref_body if s.ctrl is not None else np.zeros(3),
        "dipole_cmd_body_Am2": lambda s, d: s.ctrl.dipole_cmd_body if s.ctrl is not None else np.zeros(3),
        "B_body_T": lambda s, d: s.ctrl.B_body if s.ctrl is not None else np.zeros(3),
        "torques_world_Nm": torque_probe,
    }


def rigid_torque_probe(
    areas_body_m2: np.ndarray, field_world_T: np.ndarray | None, gg_load: GravityGradientTorqueLoad | None
) -> Probe:
    """(2, 3): magnetic torque ``(R Σ I_L a_L) × B`` and gravity-gradient torque (world axes) of the
    rigid surrogate (body 1); ``areas_body_m2`` (L, 3) vector areas, ``field_world_T`` the fixed
    field (``None``: the orbit's ``B_eci``)."""

    def probe(s, d):
        mag = np.zeros(3)
        gg = gg_load.torque_world(s) if gg_load is not None else np.zeros(3)
        if s.ctrl is not None:
            R = matrix_from_quat(s.xquat[1])
            B = field_world_T if field_world_T is not None else s.env.B_eci
            mag = np.cross(R @ (np.asarray(s.ctrl.currents_A) @ areas_body_m2), B)
        return np.stack([mag, gg])

    return probe


def flexible_torque_probe(
    node_bodies: np.ndarray,
    masses: np.ndarray,
    lorentz: LorentzLoad,
    segments: CircuitSegments,
    tidal: TidalGravityLoad | None,
) -> Probe:
    """(2, 3): Lorentz torque Σ (x_i − c) × F_i and tidal torque Σ (x_i − c) × m_i a_i about the
    centre of mass ``c`` (world axes) at this state."""
    nb, m = node_bodies, masses

    def probe(s, d):
        x = s.pos[nb]
        c = (m @ x) / m.sum()
        r = x - c
        mag = np.zeros(3)
        if s.ctrl is not None:
            B = lorentz.field(s)
            mag = np.cross(r, lorentz_node_forces(x, segments, s.ctrl.currents_A, B)).sum(axis=0)
        gg = np.zeros(3)
        if tidal is not None:
            a = tidal.accelerations(np.asarray(s.env.r_ref_eci), x)
            gg = np.cross(r, m[:, None] * a).sum(axis=0)
        return np.stack([mag, gg])

    return probe


# =========================================================================== metrics


def first_time_below(t: np.ndarray, x: np.ndarray, level: float) -> float | None:
    """First time ``x`` is below ``level`` (``None`` if never)."""
    idx = np.flatnonzero(x < level)
    return float(t[idx[0]]) if idx.size else None


def structural_series(
    lm: LoopsModel, positions: NodeTrajectory | np.ndarray, *, modes: Callable[[], Modes] | None = None
) -> dict[str, np.ndarray]:
    """Strain energy ½ Σ k (|r_j − r_i| − L)² [J] and largest strut strain
    (:mod:`magsail_mj.analysis.energy`), best fit, thickness, residual and modal amplitudes of
    node positions (T, n, 3) [m]: an array, or a :class:`~magsail_mj.lattice.trajectory.NodeTrajectory`
    reading the recorded qpos block by block.

    Every series is a function of one record, so they are computed block by block: the memory of
    post-processing does not grow with the run's length. ``modes`` gives the lattice's modes
    (their amplitudes, normalised by their largest magnitude over the run, are a diagnostic: left
    out when the modes cannot be had).

    Raises:
      ValueError: there are no records.
    """
    md = _modes_or_none(modes)
    fold = FoldAngle(lm.lattice.nodes)
    out = as_trajectory(positions).map(lambda x: _structural_block(lm, x, md, fold))
    if md is not None and "modal_amplitude" in out:
        q = out["modal_amplitude"]
        out["modal_amplitude"] = q / max(np.abs(q).max(), 1e-300)
        sl = md.elastic
        out["modal_omega_rad_s"] = md.omega[sl.start : sl.start + N_MODAL]
    return out


def _modes_or_none(modes: Callable[[], Modes] | None) -> Modes | None:
    """The lattice's modes, or None when none are asked for or they cannot be had."""
    if modes is None:
        return None
    try:
        return modes()
    except Exception:  # noqa: BLE001 - modes are a diagnostic; never lose a run for them
        return None


def _structural_block(lm: LoopsModel, x: np.ndarray, md: Modes | None, fold: FoldAngle) -> dict[str, np.ndarray]:
    """:func:`structural_series` of one block of node positions ``x`` (B, n, 3) [m]; the modal
    amplitudes ``φᵀ M u`` are not yet normalised."""
    lat = lm.lattice
    p0 = lat.nodes
    R, _ = BestFitRotation(p0)(x)
    c = x.mean(axis=1)
    xb = np.einsum("tji,tnj->tni", R, x - c[:, None, :])  # R^T (x - c)
    u = xb - (p0 - p0.mean(axis=0))
    out = {
        "strain_energy_J": strain_energy(x, lat.struts, lm.k, lat.rest_length),
        "rotation_angle_rad": rotation_angle(R),
        "R_bestfit": R,
        "thickness_m": xb[:, :, 2].max(axis=1) - xb[:, :, 2].min(axis=1),
        "rigid_fit_residual_m": np.sqrt((u**2).sum(axis=2).mean(axis=1)),
        "strut_strain_max": np.abs(strut_strain(x, lat.struts, lat.rest_length)).max(axis=1),
        "stretch_x_m": np.ptp(xb[:, :, 0], axis=1) - np.ptp(p0[:, 0]),
        "stretch_y_m": np.ptp(xb[:, :, 1], axis=1) - np.ptp(p0[:, 1]),
        "fold_angle_rad": fold(x),
    }
    if md is not None:
        try:
            sl = md.elastic
            phi = md.phi[:, sl.start : sl.start + N_MODAL]
            out["modal_amplitude"] = (u.reshape(u.shape[0], -1) * md.mass_diag) @ phi
        except Exception:  # noqa: BLE001 - as above
            pass
    return out


def plate_halves(nodes: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The two halves of a plate for each of four dividing lines through its centre (in its own
    plane xy, from the undeformed ``nodes`` (n, 3) [m]): the two mid-lines x = x_c and y = y_c and
    the two diagonals (x − x_c) ∓ (y − y_c) = 0 scaled by the plate's extents. Nodes on a line
    belong to neither half. Returns (index array, index array) per line."""
    c = 0.5 * (nodes.min(axis=0) + nodes.max(axis=0))
    ext = np.maximum(np.ptp(nodes, axis=0), 1e-300)
    u = (nodes[:, 0] - c[0]) / ext[0]
    v = (nodes[:, 1] - c[1]) / ext[1]
    tol = 1e-9
    out = []
    for d in (u, v, u - v, u + v):
        out.append((np.flatnonzero(d < -tol), np.flatnonzero(d > tol)))
    return out


class FoldAngle:
    """Fold angle [rad] of node positions ``x`` (T, n, 3) [m] against the undeformed ``nodes``
    (n, 3): for each dividing line of :func:`plate_halves`, the angle of R₁ᵀR₂ between the best
    rigid fits (Kabsch, uniform masses) R₁, R₂ of the two halves, each half fitted to its own
    undeformed nodes; the largest over the four lines, per record. A plate turned as a whole has
    fold angle 0; one folded along a mid-line or a diagonal through θ, θ (a twist shows too).
    The halves and their fits are built once; calling it on a block of records is the only work."""

    def __init__(self, nodes: np.ndarray):
        self._fits = [(a, BestFitRotation(nodes[a]), b, BestFitRotation(nodes[b])) for a, b in plate_halves(nodes)]

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        worst = np.zeros(x.shape[0])
        for a, fit_a, b, fit_b in self._fits:
            Ra, _ = fit_a(x[:, a])
            Rb, _ = fit_b(x[:, b])
            worst = np.maximum(worst, rotation_angle(Rb, relative_to=Ra))
        return worst


def fold_angle(nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """:class:`FoldAngle` of ``nodes`` applied to ``x`` (T, n, 3) [m], in [rad]."""
    return FoldAngle(nodes)(x)


def _at(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    i = int(np.argmax(y))
    return float(y[i]), float(t[i])


def stretch_keys(
    t: np.ndarray, stretch: dict[str, np.ndarray], *, late_fraction: float = LATE_FRACTION
) -> dict[str, Any]:
    """Per axis ``a`` of ``stretch`` (name → (T,) extent change [m], e.g. ``{"x": s_x}``): the
    signed extremum ``stretch_a_extremum_m`` (largest ``|s|``), its sign ``stretch_a_sign`` (+1
    stretched, −1 compressed, 0 never deformed), and over the late part ``t ≥ t_0 + f (t_end − t_0)``
    the half-swing ``stretch_a_half_swing_m = ½ (max s − min s)`` and the mean
    ``stretch_a_late_mean_m`` it swings about.

    Raises:
      ValueError: ``late_fraction`` outside [0, 1).
    """
    if not 0.0 <= late_fraction < 1.0:
        raise ValueError(f"late_fraction: must be in [0, 1), got {late_fraction!r}")
    t = np.asarray(t, dtype=float)
    late = t >= t[0] + late_fraction * (t[-1] - t[0])
    out: dict[str, Any] = {}
    for axis, s in stretch.items():
        s = np.asarray(s, dtype=float)
        ext = float(s[int(np.argmax(np.abs(s)))])
        out[f"stretch_{axis}_extremum_m"] = ext
        out[f"stretch_{axis}_sign"] = int(np.sign(ext))
        out[f"stretch_{axis}_half_swing_m"] = 0.5 * float(np.ptp(s[late]))
        out[f"stretch_{axis}_late_mean_m"] = float(np.mean(s[late]))
    return out


def strain_energy_peaks(t: np.ndarray, U: np.ndarray, *, prominence: float = PEAK_PROMINENCE) -> dict[str, Any]:
    """Peaks of the strain energy ``U`` (T,) [J] with a prominence of at least ``prominence ×
    max U`` (``scipy.signal.find_peaks``; the series is closed by a zero after its end, so a run
    still rising at its end counts its last sample): ``strain_energy_peak_count``,
    ``strain_energy_peak_times_s`` and ``t_strain_energy_max_frac`` = ``(t(max U) − t_0) /
    (t_end − t_0)``."""
    t = np.asarray(t, dtype=float)
    U = np.asarray(U, dtype=float)
    top = float(np.max(U)) if U.size else 0.0
    idx = np.zeros(0, dtype=int)
    if top > 0:
        idx, _ = find_peaks(np.append(U, 0.0), prominence=prominence * top)
    span = t[-1] - t[0]
    return {
        "strain_energy_peak_count": int(idx.size),
        "strain_energy_peak_times_s": [float(t[i]) for i in idx],
        "t_strain_energy_max_frac": float((t[int(np.argmax(U))] - t[0]) / span) if span > 0 else 0.0,
    }


def saturation_intervals(t: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(k, 2) start and end times [s] of the runs of ``True`` in ``mask`` (T,): an interval starts
    at its first ``True`` sample and ends at the next ``False`` sample (the last time if it lasts
    to the end)."""
    t = np.asarray(t, dtype=float)
    m = np.asarray(mask, dtype=bool)
    edges = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    start = np.flatnonzero(edges == 1)
    stop = np.flatnonzero(edges == -1)  # first False after the run (T if none)
    return np.column_stack([t[start], t[np.minimum(stop, t.size - 1)]]) if start.size else np.zeros((0, 2))


def saturation_keys(t: np.ndarray, saturated: np.ndarray, *, t_peak_s: float | None = None) -> dict[str, Any]:
    """Saturation of a slew's current command, ``saturated`` (T, L) per circuit axis: intervals of
    any clipped axis (:func:`saturation_intervals`; the first :data:`N_INTERVALS_LISTED` listed),
    their count, total time [s], first start and last end [s], per-axis interval counts, and with
    ``t_peak_s`` the 0-based interval holding that time (``None`` if none)."""
    sat = np.asarray(saturated, dtype=bool)
    iv = saturation_intervals(t, np.any(sat, axis=1))
    holding = None
    if t_peak_s is not None:
        hit = np.flatnonzero((iv[:, 0] <= t_peak_s) & (t_peak_s <= iv[:, 1]))
        holding = int(hit[0]) if hit.size else None
    return {
        "saturation_interval_count": int(iv.shape[0]),
        "saturation_intervals_s": iv[:N_INTERVALS_LISTED].tolist(),
        "saturated_time_s": float(np.sum(iv[:, 1] - iv[:, 0])),
        "saturation_first_start_s": float(iv[0, 0]) if iv.size else None,
        "saturation_last_end_s": float(iv[-1, 1]) if iv.size else None,
        "saturation_interval_count_per_axis": [
            int(saturation_intervals(t, sat[:, j]).shape[0]) for j in range(sat.shape[1])
        ],
        "saturation_interval_at_strain_energy_max": holding,
    }


def modal_strain_energies(md: Modes, nodes: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(B, K) strain energy ``½ ω_n² q_n²`` [J] of every elastic mode of node positions ``x``
    (B, n, 3) [m]: the body-frame deformation ``u = R_θᵀ (x − c) − (p − p̄)`` (best fit ``R_θ``,
    centroid ``c``, undeformed ``nodes`` ``p``; uniform masses) projected as ``q_n = φ_nᵀ M u``."""
    p0 = np.asarray(nodes, dtype=float)
    R, _ = BestFitRotation(p0)(x)
    c = x.mean(axis=1)
    u = np.einsum("tji,tnj->tni", R, x - c[:, None, :]) - (p0 - p0.mean(axis=0))
    sl = md.elastic
    q = (u.reshape(u.shape[0], -1) * md.mass_diag) @ md.phi[:, sl]
    return 0.5 * md.omega[sl] ** 2 * q**2


def modal_energy_profile(
    md: Modes, nodes: np.ndarray, positions: NodeTrajectory | np.ndarray, *, index: int
) -> tuple[np.ndarray, np.ndarray]:
    """Elastic modal strain energies (:func:`modal_strain_energies`) at record ``index`` and
    averaged over all records, ``(K,)`` each [J], read block by block."""
    traj = as_trajectory(positions)
    total = np.zeros(md.n_dof - md.n_rigid)
    for x in traj.blocks():
        total += modal_strain_energies(md, nodes, x).sum(axis=0)
    at = modal_strain_energies(md, nodes, traj.at(index)[None])[0]
    return at, total / len(traj)


def dominant_modes(omega: np.ndarray, energy: np.ndarray, *, prefix: str, count: int = N_DOMINANT) -> dict[str, Any]:
    """The ``count`` elastic modes of largest ``energy`` (K,) [J] (``omega`` (K,) [rad/s]): their
    elastic mode numbers (from 1), ``ω`` [rad/s], periods [s] and shares of ``Σ energy``, as keys
    ``{prefix}_mode``, ``_omega_rad_s``, ``_period_s``, ``_share``; ``{prefix}_energy_sum_J``."""
    e = np.asarray(energy, dtype=float)
    tot = float(e.sum())
    idx = np.argsort(e)[::-1][:count]
    w = np.asarray(omega, dtype=float)[idx]
    return {
        f"{prefix}_mode": [int(i) + 1 for i in idx],
        f"{prefix}_omega_rad_s": w.tolist(),
        f"{prefix}_period_s": (2 * np.pi / w).tolist(),
        f"{prefix}_share": (e[idx] / tot).tolist() if tot > 0 else [0.0] * idx.size,
        f"{prefix}_energy_sum_J": tot,
    }


@dataclass(frozen=True)
class ModalEnergySummary:
    """Elastic modal strain energies ``E_n`` (:func:`modal_strain_energies`) of a run, (K,) each [J]:
    at one record (``at``), averaged over all records (``mean``) and over the records of the
    closing window ``t ≥ t_end − window_s`` (``window_mean``); and the share of the first ``first``
    elastic modes ``s(t) = Σ_{n ≤ first} E_n(t) / Σ_n E_n(t)``: its mean over the records with
    ``Σ_n E_n > 0`` (``share_first_mean``), over those of the window (``share_first_window``) and at
    the one record (``share_first_at``); ``None`` where no record has strain energy."""

    at: np.ndarray
    mean: np.ndarray
    window_mean: np.ndarray
    share_first_at: float | None
    share_first_mean: float | None
    share_first_window: float | None
    first: int
    window_s: float


def modal_energy_stats(
    t: np.ndarray,
    energies: Iterable[np.ndarray],
    *,
    index: int,
    window_s: float = LAST_WINDOW_S,
    first: int = N_FIRST_MODES,
) -> ModalEnergySummary:
    """:class:`ModalEnergySummary` of the modal strain energies ``energies`` [J], given as (B, K)
    blocks in record order that together cover the records of ``t`` (T,) [s] (one (T, K) array
    may be passed as ``[E]``). The records are taken as equally spaced, so a time mean is the mean
    over records; the share ``s(t)`` is averaged record by record (not weighted by the energy, unlike
    the shares of :func:`dominant_modes` over a run).

    Raises:
      ValueError: ``window_s`` not positive, ``first`` below 1, ``index`` outside the records, or
        blocks that do not cover ``t``.
    """
    if not window_s > 0:
        raise ValueError(f"window_s: must be positive, got {window_s!r}")
    if first < 1:
        raise ValueError(f"first: must be at least 1, got {first!r}")
    t = np.asarray(t, dtype=float)
    if not 0 <= index < t.size:
        raise ValueError(f"index: must be in [0, {t.size}), got {index!r}")
    in_window = t >= t[-1] - window_s
    total = window = None
    at = None
    share_sum = share_win_sum = 0.0
    share_n = share_win_n = 0
    k0 = 0
    for E in energies:
        E = np.asarray(E, dtype=float)
        k1 = k0 + E.shape[0]
        if k1 > t.size:
            raise ValueError(f"energies: blocks hold more records than t ({t.size})")
        w = in_window[k0:k1]
        if total is None:
            total = np.zeros(E.shape[1])
            window = np.zeros(E.shape[1])
        total += E.sum(axis=0)
        window += E[w].sum(axis=0)
        if k0 <= index < k1:
            at = E[index - k0].copy()
        row = E.sum(axis=1)
        pos = row > 0
        share = E[pos, :first].sum(axis=1) / row[pos]
        share_sum += float(share.sum())
        share_n += int(pos.sum())
        share_win_sum += float(share[w[pos]].sum())
        share_win_n += int(np.count_nonzero(w & pos))
        k0 = k1
    if k0 != t.size or total is None or window is None or at is None:
        raise ValueError(f"energies: blocks hold {k0} records, t holds {t.size}")
    at_total = float(at.sum())
    return ModalEnergySummary(
        at=at,
        mean=total / t.size,
        window_mean=window / int(in_window.sum()),
        share_first_at=float(at[:first].sum() / at_total) if at_total > 0 else None,
        share_first_mean=share_sum / share_n if share_n else None,
        share_first_window=share_win_sum / share_win_n if share_win_n else None,
        first=first,
        window_s=window_s,
    )


def modal_energy_summary(
    md: Modes,
    nodes: np.ndarray,
    positions: NodeTrajectory | np.ndarray,
    *,
    t: np.ndarray,
    index: int,
    window_s: float = LAST_WINDOW_S,
    first: int = N_FIRST_MODES,
) -> ModalEnergySummary:
    """:func:`modal_energy_stats` of the elastic modal strain energies (:func:`modal_strain_energies`)
    of node ``positions`` recorded at ``t`` (T,) [s], read block by block."""
    traj = as_trajectory(positions)
    if len(traj) != len(t):
        raise ValueError(f"t: {len(t)} times for {len(traj)} records")
    blocks = (modal_strain_energies(md, nodes, x) for x in traj.blocks())
    return modal_energy_stats(t, blocks, index=index, window_s=window_s, first=first)


def first_modes_share_keys(s: ModalEnergySummary) -> dict[str, float | None]:
    """``modal_energy_share_first{N}_mean``, ``_at_Umax`` and ``_last{W}s`` of ``s`` (``N = s.first``,
    ``W = s.window_s``; the record ``s.at`` is taken at the maximum of U)."""
    stem = f"modal_energy_share_first{s.first}"
    return {
        f"{stem}_mean": s.share_first_mean,
        f"{stem}_at_Umax": s.share_first_at,
        f"{stem}_last{s.window_s:g}s": s.share_first_window,
    }


def error_swing_keys(
    t: np.ndarray,
    err_rad: np.ndarray,
    *,
    settle_deg: float = SWING_SETTLE_DEG,
    prominence_fraction: float = SWING_PROMINENCE_FRACTION,
) -> dict[str, Any]:
    """Swings of the attitude error ``err_rad`` (T,) [rad] about the target after it first comes
    within ``settle_deg`` (at ``t_5``, :func:`first_time_below`): the local maxima and minima of
    ``θ(t)`` [deg] over ``t ≥ t_5`` (``scipy.signal.find_peaks`` on ``θ`` and ``−θ``) whose
    prominence is at least ``prominence_fraction × (max θ − min θ)`` over that part.

    The threshold is relative to the largest swing so that it scales with the response: the
    extrema of the swings themselves count until they have decayed below 2 % (the default) of the
    largest, while the ripple on the recorded error (the flexible plate's best-fit attitude jitters
    at its elastic periods, and the record samples a smooth turn every few seconds) is far below it
    and does not split one swing into several. A planar swing through the target has cusp minima
    ``θ ≈ 0`` at the crossings; they count as minima like any other.

    Keys: ``error_extrema_count``; the first :data:`N_EXTREMA_LISTED` extrema in time order as
    ``error_extrema_t_s`` [s] and ``error_extrema_deg`` [deg]; ``error_half_swing_s`` [s], the
    times between successive extrema ``t_{k+1} − t_k`` (half a period of a regular swing), of those
    listed; ``error_half_swing_mean_s`` [s], their mean over all extrema (``None`` with fewer than
    two). No extremum (and empty lists) if the error never comes within ``settle_deg``.

    Raises:
      ValueError: ``prominence_fraction`` outside (0, 1].
    """
    if not 0.0 < prominence_fraction <= 1.0:
        raise ValueError(f"prominence_fraction: must be in (0, 1], got {prominence_fraction!r}")
    t = np.asarray(t, dtype=float)
    err = np.asarray(err_rad, dtype=float)
    t_in = first_time_below(t, err, np.radians(settle_deg))
    idx = np.zeros(0, dtype=int)
    if t_in is not None:
        after = np.flatnonzero(t >= t_in)
        deg = np.degrees(err[after])
        swing = float(np.ptp(deg))
        if swing > 0:
            hi, _ = find_peaks(deg, prominence=prominence_fraction * swing)
            lo, _ = find_peaks(-deg, prominence=prominence_fraction * swing)
            idx = after[np.sort(np.concatenate([hi, lo]))]
    te = t[idx]
    half = np.diff(te)
    return {
        "error_extrema_count": int(idx.size),
        "error_extrema_t_s": te[:N_EXTREMA_LISTED].tolist(),
        "error_extrema_deg": np.degrees(err[idx[:N_EXTREMA_LISTED]]).tolist(),
        "error_half_swing_s": half[: N_EXTREMA_LISTED - 1].tolist(),
        "error_half_swing_mean_s": float(half.mean()) if half.size else None,
    }


def shape_keys(t: np.ndarray, st: dict[str, np.ndarray]) -> dict[str, Any]:
    """Stretch (:func:`stretch_keys`, body ``x`` and ``y``) and strain-energy peak
    (:func:`strain_energy_peaks`) keys of :func:`structural_series` ``st``."""
    out = strain_energy_peaks(t, st["strain_energy_J"])
    if "stretch_x_m" in st:
        out.update(stretch_keys(t, {"x": st["stretch_x_m"], "y": st["stretch_y_m"]}))
    return out


def base_summary(result: RunResult) -> dict[str, Any]:
    """Status, message, end time [s] and wall time [s] of a run."""
    return {
        "status": result.status,
        "status_message": result.message,
        "t_end_s": result.t_end_s,
        "wall_time_s": result.wall_time_s,
    }


def classify(
    c: ClassificationConfig,
    *,
    criteria: list[str],
    side_m: float,
    rho_max: float,
    dev_max: float,
) -> str:
    """Classification: ``collapsed`` if any collapse criterion is met (``criteria``, from
    :func:`classification_keys`: ρ_max > f_c D, strain > ε_c, h_max > n_c w, w = D / N);
    ``rigid_like`` if ρ_max < f_r D and the rotation stays within the angle tolerance of the rigid
    reference (``dev_max`` [rad]); else ``flexible``."""
    if criteria:
        return "collapsed"
    if rho_max < c.rigid_residual_frac * side_m and dev_max <= np.radians(c.rigid_angle_tol_deg):
        return "rigid_like"
    return "flexible"


def classification_keys(
    c: ClassificationConfig,
    *,
    side_m: float,
    units: int,
    rho_max: float,
    strain_max: float,
    h_max: float,
    dev_max: float,
) -> dict[str, Any]:
    """``collapse_criteria``: the collapse criteria a run meets, in this order: ``"residual"``
    (ρ_max > f_c D), ``"strain"`` (largest strut strain > ε_c), ``"thickness"`` (h_max > n_c w,
    w = D / N); ``classification`` (:func:`classify` over all of them) and
    ``classification_by_shape`` (the strain criterion left out, so that a run stopped at the strain
    bound is classed by the shape it had reached)."""
    bounds = {
        "residual": rho_max > c.collapse_residual_frac * side_m,
        "strain": strain_max > c.collapse_strain,
        "thickness": h_max > c.collapse_thickness_units * side_m / units,
    }
    met = [name for name, exceeded in bounds.items() if exceeded]
    shape = [m for m in met if m != "strain"]
    return {
        "classification": classify(c, criteria=met, side_m=side_m, rho_max=rho_max, dev_max=dev_max),
        "classification_by_shape": classify(c, criteria=shape, side_m=side_m, rho_max=rho_max, dev_max=dev_max),
        "collapse_criteria": met,
    }


def fold_keys(t: np.ndarray, st: dict[str, np.ndarray]) -> dict[str, float]:
    """``fold_angle_max_deg`` [deg] and its time ``t_fold_angle_max_s`` [s] (:func:`fold_angle`)."""
    a_max, t_a = _at(t, st["fold_angle_rad"])
    return {"fold_angle_max_deg": float(np.degrees(a_max)), "t_fold_angle_max_s": t_a}


def sweep_metrics(
    lm: LoopsModel,
    rec: dict[str, np.ndarray],
    st: dict[str, np.ndarray],
    *,
    inertia_kgm2: np.ndarray,
    areas_body_m2: np.ndarray,
    field_world_T: np.ndarray,
    work_names: list[str],
    segments: CircuitSegments,
    stability_product_max: float,
    classification: ClassificationConfig,
    side_m: float,
    units: int,
) -> Metrics:
    """Metrics of a constant-current run in the fixed field ``field_world_T`` [T]: the rigid
    reference with the realised dipole m = Σ I_L a_L [A m²], the flexible run's deviation from it,
    the dipole–field angle at the time of maximum strain energy, the energy balance
    E_kin + U − W_Lorentz − W_damping (relative to max |W_Lorentz|; ``work_names`` order the
    recorded ``work_J`` columns; with a linear stiffness load, named ``"stiffness"``, its work
    −W_stiffness takes the place of U, the printed Eq. 12 having no potential), the self-field
    estimate and the classification (:func:`classify`).
    ``st``: :func:`structural_series` of the recorded node positions."""
    t = rec["t"]
    U = st["strain_energy_J"]
    B = field_world_T
    currents = lm.currents_A
    m_body = currents @ areas_body_m2
    # rigid reference with the realised dipole
    R_rig, _ = rigid_dipole_attitude(t, inertia=inertia_kgm2, dipole_body=m_body, field_world=B)
    ang_rig = rotation_angle(R_rig)
    ang = st["rotation_angle_rad"]
    dev = rotation_angle(st["R_bestfit"], relative_to=R_rig)
    # dipole–field angle: realised dipole direction in the world
    m_world = np.einsum("tij,j->ti", st["R_bestfit"], m_body)
    cosang = m_world @ B / (np.linalg.norm(m_world, axis=1) * np.linalg.norm(B))
    dip_field = np.arccos(np.clip(cosang, -1, 1))
    U_max, t_U = _at(t, U)
    iU = int(np.argmax(U))
    ke = rec["kinetic_energy_J"]
    work = rec.get("work_J")
    names = work_names
    W_L = work[:, names.index("lorentz")] if work is not None and "lorentz" in names else np.zeros_like(t)
    W_D = work[:, names.index("damping")] if work is not None and "damping" in names else np.zeros_like(t)
    linear = work is not None and "stiffness" in names
    W_K = work[:, names.index("stiffness")] if linear else None
    # a linear stiffness load (stiffness.form) has no potential: its work replaces the strain energy
    residual = ke - W_L - W_D - W_K if linear else ke + U - W_L - W_D
    scale = max(np.abs(W_L).max(), 1e-300)
    rho_max = float(st["rigid_fit_residual_m"].max())
    strain_max = float(st["strut_strain_max"].max())
    h_max = float(st["thickness_m"].max())
    dev_max = float(dev.max())
    summary = {
        "current_A": float(currents[0]) if currents.size == 1 else [float(v) for v in currents],
        "dipole_realised_Am2": float(np.linalg.norm(m_body)),
        "strain_energy_max_J": U_max,
        "t_strain_energy_max_s": t_U,
        "thickness_max_m": h_max,
        "rigid_fit_residual_max_m": rho_max,
        "strut_strain_max": strain_max,
        "rotation_angle_max_rad": float(ang.max()),
        "rotation_angle_final_rad": float(ang[-1]),
        "rigid_rotation_angle_final_rad": float(ang_rig[-1]),
        "rotation_dev_from_rigid_max_rad": dev_max,
        "dipole_field_angle_at_Umax_rad": float(dip_field[iU]),
        "energy_balance_rel_err": float(np.abs(residual).max() / scale),
        "lorentz_work_final_J": float(W_L[-1]),
        "damping_work_final_J": float(W_D[-1]),
        **({"stiffness_work_final_J": float(W_K[-1])} if linear else {}),
        "stability_product_max": stability_product_max,
        "self_field_max_T": float(self_field_max_T(lm.lattice.nodes, segments, currents)),
        **classification_keys(
            classification,
            side_m=side_m,
            units=units,
            rho_max=rho_max,
            strain_max=strain_max,
            h_max=h_max,
            dev_max=dev_max,
        ),
        **fold_keys(t, st),
        **shape_keys(t, st),
    }
    series = {k: v for k, v in st.items() if k != "R_bestfit"}
    series.update(
        rotation_angle_deg=np.degrees(ang),
        rigid_rotation_angle_rad=ang_rig,
        rotation_dev_from_rigid_rad=dev,
        dipole_field_angle_rad=dip_field,
        energy_residual_J=residual,
        lorentz_work_J=W_L,
        damping_work_J=W_D,
        dipole_world_Am2=m_world,
        snapshot_index=np.array(iU),
    )
    return summary, series


def slew_metrics(rec: dict[str, np.ndarray], *, areas_body_m2: np.ndarray) -> Metrics:
    """Attitude metrics of a slew: error 2 atan2(|q_e,xyz|, |q_e,w|) [rad], times below 5° and 2°, largest
    error after first reaching 5°, its swings after that (:func:`error_swing_keys`), saturation
    fraction, torques, achieved dipole Σ I_L a_L [A m²] and the largest current per axis [A]."""
    t = rec["t"]
    qe = rec["q_err"]
    err = quat_angle(qe)
    t5 = first_time_below(t, err, np.radians(5.0))
    t2 = first_time_below(t, err, np.radians(2.0))
    after = t >= t5 if t5 is not None else np.zeros_like(t, dtype=bool)
    if np.any(after):
        i = np.flatnonzero(after)[np.argmax(err[after])]
        err_after, t_err_after = float(err[i]), float(t[i])
    else:
        err_after, t_err_after = None, None
    sat = rec["saturated"].astype(bool)
    torques = rec["torques_world_Nm"]
    mag = np.linalg.norm(torques[:, 0], axis=1)
    gg = np.linalg.norm(torques[:, 1], axis=1)
    currents_axis = rec["currents_axis_A"]
    m_ach = np.einsum("tl,lj->tj", rec["currents_A"], areas_body_m2)
    summary: dict[str, Any] = {
        "t_err_below_5deg_s": t5,
        "t_err_below_2deg_s": t2,
        "err_max_after_settle_rad": err_after,
        "t_err_max_after_settle_s": t_err_after,
        "err_final_rad": float(err[-1]),
        "saturation_fraction": float(np.mean(np.any(sat, axis=1))),
        "mag_torque_max_Nm": float(mag.max()),
        "gg_torque_max_Nm": float(gg.max()),
        # names shared with the other concepts' slew summaries
        "time_to_target_s": t5,
        "attitude_error_max_after_target_deg": None if err_after is None else float(np.degrees(err_after)),
        "current_max_A": [float(v) for v in np.abs(currents_axis).max(axis=0)],
        **error_swing_keys(t, err),
    }
    series = {
        "error_angle_rad": err,
        "error_angle_deg": np.degrees(err),
        "mag_torque_world_Nm": torques[:, 0],
        "gg_torque_world_Nm": torques[:, 1],
        "dipole_achieved_body_Am2": m_ach,
    }
    try:
        eul = euler_zyx(matrix_from_quat(rec["q"]))
        series["euler_zyx_rad"] = np.stack(eul, axis=-1) if isinstance(eul, tuple) else eul
    except Exception:  # noqa: BLE001 - a plotting aid only
        pass
    return summary, series


def slew_structure(t: np.ndarray, st: dict[str, np.ndarray]) -> Metrics:
    """Structural keys of a flexible slew from :func:`structural_series` ``st``: largest strain
    energy [J] and its time [s], residual [m], strut strain, thickness [m]; the snapshot index."""
    U = st["strain_energy_J"]
    U_max, t_U = _at(t, U)
    summary = dict(
        strain_energy_max_J=U_max,
        t_strain_energy_max_s=t_U,
        time_strain_max_s=t_U,
        rigid_fit_residual_max_m=float(st["rigid_fit_residual_m"].max()),
        strut_strain_max=float(st["strut_strain_max"].max()),
        thickness_max_m=float(st["thickness_m"].max()),
        **fold_keys(t, st),
        **shape_keys(t, st),
    )
    series = {k: v for k, v in st.items() if k != "R_bestfit"}
    series["snapshot_index"] = np.array(int(np.argmax(U)))
    return summary, series
