r"""MSAC tasks: one class per scenario kind (config key ``scenario``), registered by name.

* ``"lumped"`` → :class:`LumpedTask`: analytic only, Eqs. (6)–(7) (with our sign
  correction) and the exact planar model; no MuJoCo steps
  (:class:`magsail_mj.concepts.msac.runner.StaticRunner`).
* ``"multibody"`` → :class:`MultibodyTask`: the MuJoCo model driven along the cycle by the
  native-rollout / computed-torque runner (:class:`magsail_mj.concepts.msac.runner.MsacRunner`).
* ``"sweep"`` → :class:`SweepTask`: a base config plus a ``[sweep]`` table; :class:`SweepRunner`
  runs a :class:`MultibodyTask` per point (F6, F7).

Each class is registered with :func:`magsail_mj.concepts.register_task` keyed by
``("msac", scenario)``; :func:`magsail_mj.concepts.build_task` looks it up once.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.concepts.msac.metrics import (
    cycle_increments,
    filtered_rate,
    max_cycle_rate,
    secular_rate_fit,
    unwrapped_yaw,
)
from magsail_mj.concepts.msac.cycle import cycle_state
from magsail_mj.concepts.msac.reference import exact_rotation_samples
from magsail_mj.concepts import build_task, register_task
from magsail_mj.concepts.msac.mjcf import shape_indices
from magsail_mj.concepts.msac.config import PAPER_VALUES, PLACEHOLDERS, MsacConfig, flatten_keys, point_config
from magsail_mj.concepts.msac.model import MsacModel
from magsail_mj.concepts.msac.plots import msac_plots, sweep_plot
from magsail_mj.concepts.msac.runner import MsacRunner, StaticRunner
from magsail_mj.sim import RunResult, WholeRun

__all__ = [
    "MsacTask",
    "LumpedTask",
    "MultibodyTask",
    "SweepTask",
    "SweepRunner",
    "build_msac_scenario",
    "multibody_summary",
    "phase_labels",
]


class MsacTask(ABC):
    """What every MSAC task shares: the built MSAC (``msac``; ``params``, ``path``, ``spec``,
    ``model``, ``planar`` from it), the analytic references, the video settings and the manifest.
    Subclasses set the runner, the outputs and the video overlay."""

    #: series shown over the video
    overlay: tuple[str, ...] = ()

    def __init__(self, cfg: MsacConfig) -> None:
        self.cfg = cfg
        self.msac = MsacModel(cfg)
        self.params, self.path, self.spec = self.msac.params, self.msac.path, self.msac.spec
        self.model, self.planar = self.msac.model, self.msac.planar
        self.runner: Any = None
        self.last_summary: dict[str, Any] = {}

    def references(self) -> dict[str, float]:
        """Analytic summary entries (see :meth:`MsacModel.references`)."""
        return self.msac.references()

    @abstractmethod
    def simulation(self) -> Any:
        """The kind's runner (``run()`` → :class:`~magsail_mj.sim.RunResult`)."""

    @abstractmethod
    def summarise(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The kind's summary keys and derived series from a run's result."""

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Summary and derived series (yaw, increments)."""
        summary, series = self.summarise(result)
        self.last_summary = summary
        return summary, series

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return []

    def render_info(self) -> dict[str, Any]:
        r, cfg = self.cfg.render, self.cfg
        reach = cfg.wings.hinge_offset_m + cfg.wings.length_m
        return {
            "title": f"MSAC {cfg.scenario}: {cfg.description}".strip(": ")[:80],
            "overlay": list(self.overlay),
            "overlay_names": {"yaw_unwrapped_rad": "bus yaw ψ (unwrapped)", "phase": "cycle phase"},
            "overlay_labels": {"phase": phase_labels(self.path.waypoints)},
            "markers": {
                "w1_panel": "wing 1",
                "w2_panel": "wing 2",
                "bus_box": "bus",
                "bus_tag": "bus tag (shows the bus's own turn)",
                "world_marker": "fixed world marker (+X)",
            },
            "camera": {
                "azimuth_deg": r.azimuth_deg,
                "elevation_deg": r.elevation_deg,
                "distance_m": r.distance_m or 2.6 * reach,
            },
            "fps": r.fps,
            "max_frames": r.max_frames,
            "extension_exaggeration": r.extension_exaggeration,
        }

    def manifest_extra(self) -> dict[str, Any]:
        cfg = self.cfg
        flat = flatten_keys(cfg.model_dump(mode="json"))
        table = {}
        for key in list(PAPER_VALUES) + list(PLACEHOLDERS):
            if key not in flat:
                continue
            v = flat[key]
            if key in PAPER_VALUES:
                src = "paper" if v == PAPER_VALUES[key] else f"config (paper: {PAPER_VALUES[key]})"
            else:
                src = "placeholder"
            table[key] = {"value": v, "source": src}
        m = self.model
        return {
            "model_size": {"bodies": int(m.nbody), "dofs": int(m.nv), "actuators": int(m.nu)},
            "parameters": table,
            "solver": {
                "integrator": cfg.sim.integrator,
                "timestep_s": cfg.sim.timestep_s,
                "steps_per_cycle": int(round(1 / (cfg.cycle.frequency_Hz * cfg.sim.timestep_s))),
                "drive": cfg.drive.method,
                "omega_c_dt": cfg.drive.omega_c_dt,
                "momentum_projection": cfg.drive.projection,
                "servo_omega_dt": cfg.drive.servo_omega_dt,
                "disableflags": int(m.opt.disableflags),
            },
        }


def phase_labels(waypoints: np.ndarray) -> dict[str, str]:
    """What the shape does in each recorded ``phase`` (1 … 4: segment k of the cycle from waypoint
    k − 1 to k of ``waypoints`` (5, 2) = ``(φ [rad], s [m])``, the first repeated), for the video
    overlay: ``bend``/``bend back`` when φ moves away from/back to its first value, with the slide
    state (extended at the first waypoint's s, else contracted), ``extend``/``contract`` when s
    moves, ``hold`` when neither does."""
    w = np.asarray(waypoints, dtype=float)
    phi_a, s_e = w[0]
    out = {}
    for k in range(w.shape[0] - 1):
        (phi0, s0), (phi1, s1) = w[k], w[k + 1]
        moves = []
        if phi1 != phi0:
            slide = "extended" if s0 == s_e else "contracted"
            moves.append(("bend back" if phi1 == phi_a else "bend") + f" ({slide})")
        if s1 != s0:
            moves.append("extend" if s1 == s_e else "contract")
        out[str(k + 1)] = f"{k + 1} of {w.shape[0] - 1}, " + (" and ".join(moves) or "hold")
    return out


def momentum_yaw_error(sc: MsacModel, rec: Any, rotation_rad: float) -> dict[str, float]:
    r"""The bus rotation that the drift of the total angular momentum adds to a run.

    With total momentum ``L`` the bus turns at ``ψ̇ = (L − N_φ φ̇ − N_s ṡ)/D(φ, s)`` (the exact
    planar model), so a drift ``δL`` adds ``δψ̇ = δL/D``. Over a cycle this is ``δL·T·⟨1/D⟩``
    (``⟨1/D⟩``: the mean of ``1/D`` along the prescribed path), and over the run, with ``δL_k``
    the drift at the cycle starts (``strobe_angmom_Nms``, z),

    .. math::
        δψ = T⟨1/D⟩ \sum_k \tfrac12(δL_k + δL_{k+1}) .

    Returns ``angmom_spurious_yaw_rad`` and ``angmom_spurious_yaw_rel`` (``|δψ|`` over the
    run's net rotation ``|rotation_rad|``); NaN without two cycle starts.
    """
    L = rec.get("strobe_angmom_Nms", np.zeros((0, 3)))
    if L.shape[0] < 2:
        return {"angmom_spurious_yaw_rad": float("nan"), "angmom_spurious_yaw_rel": float("nan")}
    T = sc.path.period_s
    st = cycle_state(sc.path, np.linspace(0.0, T, 2001))
    inv_D = float(np.mean(1.0 / sc.planar.inertia_sum(st.phi, st.s)))
    dL = L[:, 2] - L[0, 2]
    err = T * inv_D * float(np.sum(0.5 * (dL[1:] + dL[:-1])))
    rel = abs(err) / abs(rotation_rad) if rotation_rad else float("nan")
    return {"angmom_spurious_yaw_rad": err, "angmom_spurious_yaw_rel": rel}


def actuation_summary(sc: MsacModel, rec: Any) -> dict[str, Any]:
    r"""What the drive demands of the shape actuators against what the configured ones deliver.

    ``hinge_torque_rms_Nm``/``slide_force_rms_N``: RMS over every step and both wings of the
    total actuator force on the joints; the peaks (``hinge_torque_peak_Nm``, ``slide_force_peak_N``)
    come with the run. Capacities ``hinge_torque_max_Nm``/``slide_force_max_N`` from
    ``[actuators]``; ``actuation_feasible`` when both peaks are within them;
    ``actuation_capacity_ratio`` = min(capacity/peak). ``max_cycle_rate_Hz``: the largest rate
    of the same path the capacities allow (:func:`~magsail_mj.concepts.msac.metrics.max_cycle_rate`:
    inertial demand ∝ rate², the slide spring's ``k_s s`` rate-independent), from the last
    full-rate window's steps after the discarded start-up cycles (NaN if none).
    """
    cfg = sc.cfg
    rms = np.asarray(rec["run_joint_force_rms"], dtype=float)
    cap_h, cap_s = cfg.actuators.hinge_torque_max_Nm, cfg.actuators.slide_force_max_N
    peak_h, peak_s = float(rec["run_hinge_torque_peak_Nm"]), float(rec["run_slide_force_peak_N"])
    out: dict[str, Any] = {
        "hinge_torque_rms_Nm": float(np.sqrt(0.5 * (rms[0] ** 2 + rms[2] ** 2))),
        "slide_force_rms_N": float(np.sqrt(0.5 * (rms[1] ** 2 + rms[3] ** 2))),
        "hinge_torque_max_Nm": cap_h,
        "slide_force_max_N": cap_s,
        "actuation_feasible": bool(peak_h <= cap_h and peak_s <= cap_s),
        "actuation_capacity_ratio": min(
            cap_h / peak_h if peak_h else float("inf"), cap_s / peak_s if peak_s else float("inf")
        ),
        "max_cycle_rate_Hz": float("nan"),
    }
    if "win_t" not in rec or not rec["win_t"].size:
        return out
    wid, wt = rec["win_id"], rec["win_t"]
    keep = (wid == wid.max()) & (wt >= cfg.post.discard_cycles * sc.path.period_s - 0.5 * cfg.sim.timestep_s)
    if not keep.any():
        return out
    F = rec["win_joint_force"][keep]
    qa = shape_indices(sc.model)["qpos"]
    S = np.zeros_like(F)
    S[:, [1, 3]] = cfg.wings.slide_stiffness_N_m * rec["win_qpos"][keep][:, qa[[1, 3]]]
    out["max_cycle_rate_Hz"] = max_cycle_rate(
        F, S, np.array([cap_h, cap_s, cap_h, cap_s]), rate_hz=cfg.cycle.frequency_Hz
    )
    return out


def multibody_summary(
    sc: MsacModel, result: RunResult, ref: dict[str, float]
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary of a multibody run of the built MSAC ``sc``: stroboscopic increments,
    two secular-rate estimates, angular-momentum drift, peak actuator loads, tracking error;
    ``ref``: the analytic references (:meth:`MsacModel.references`)."""
    cfg, rec = sc.cfg, result.records
    T = sc.path.period_s
    out: dict[str, Any] = dict(ref)
    series: dict[str, np.ndarray] = {}
    yaw_rec = unwrapped_yaw(rec["qpos"][:, 3:7]) if rec["qpos"].shape[0] else np.zeros(0)
    series["yaw_unwrapped_rad"] = yaw_rec
    st, sq = rec.get("strobe_t", np.zeros(0)), rec.get("strobe_quat", np.zeros((0, 4)))
    yaw = unwrapped_yaw(sq) if sq.shape[0] else np.zeros(0)
    series["strobe_yaw_unwrapped_rad"] = yaw
    disc = cfg.post.discard_cycles
    cycles = max(0, yaw.size - 1)
    out.update(
        {
            "cycles_simulated": cycles,
            "simulated_time_s": result.t_end_s,
            "steps": result.steps,
            "wall_time_s": result.wall_time_s,
            "wall_time_per_step_s": result.wall_time_s / max(result.steps, 1),
            "timestep_s": cfg.sim.timestep_s,
            "steps_per_cycle": int(rec["run_steps_per_cycle"]),
            "drive_method": cfg.drive.method,
            "status": result.status,
        }
    )
    exact = ref["theta_gamma_exact_rad"]
    if cycles > disc:
        inc = cycle_increments(yaw, discard=disc)
        series["strobe_increment_rad"] = inc.increments
        kept_t, kept_y = st[disc:], yaw[disc:]
        slope, _ = secular_rate_fit(kept_t, kept_y)
        one_period = inc.mean / T
        if result.t_end_s >= cfg.post.min_filter_duration_s and "omega_z_filtered_rad_s" in rec:
            filt = filtered_rate(rec["omega_filt_t"], rec["omega_z_filtered_rad_s"], edge_s=cfg.post.edge_discard_s)
            method = (
                f"butterworth order {cfg.post.lowpass_order}, {cfg.post.lowpass_cutoff_Hz:g} Hz, zero phase, "
                f"{cfg.post.edge_discard_s:g} s edges"
            )
        else:
            filt, method = one_period, "one-period average (run shorter than min_filter_duration_s)"
        out.update(
            {
                "theta_gamma_mujoco_rad": inc.mean,
                "theta_gamma_mujoco_std_rad": inc.std,
                "theta_gamma_first_cycle_rad": inc.first,
                "rate_slope_rad_s": slope,
                "rate_filtered_mean_rad_s": filt,
                "rate_filtered_method": method,
                "rate_one_period_mean_rad_s": one_period,
                "rate_estimates_rel_diff": abs(slope - filt) / abs(slope) if slope else float("nan"),
                "mujoco_vs_exact_rel_diff": (inc.mean - exact) / abs(exact) if exact else float("nan"),
                "mujoco_vs_eq6_rel_diff": (
                    (inc.mean - ref["theta_gamma_eq6_model_rad"]) / abs(ref["theta_gamma_eq6_model_rad"])
                    if ref["theta_gamma_eq6_model_rad"]
                    else float("nan")
                ),
                "secular_rate_rad_s": slope,
            }
        )
    else:
        for key in (
            "theta_gamma_mujoco_rad",
            "theta_gamma_mujoco_std_rad",
            "theta_gamma_first_cycle_rad",
            "rate_slope_rad_s",
            "rate_filtered_mean_rad_s",
            "rate_estimates_rel_diff",
            "mujoco_vs_exact_rel_diff",
            "secular_rate_rad_s",
        ):
            out[key] = float("nan")
    yaw_end = float(yaw_rec[-1] - yaw_rec[0]) if yaw_rec.size else float("nan")
    out["yaw_unwrapped_final_rad"] = yaw_end
    out["net_rotation_rad"] = yaw_end
    out["angmom_drift_max_Nms"] = float(rec["run_angmom_drift_max_Nms"])
    out["angmom_drift_z_max_Nms"] = float(rec["run_angmom_drift_z_max_Nms"])
    out["angular_momentum_drift"] = out["angmom_drift_max_Nms"] / ref["angmom_scale_Nms"]
    out["hinge_torque_peak_Nm"] = float(rec["run_hinge_torque_peak_Nm"])
    out["slide_force_peak_N"] = float(rec["run_slide_force_peak_N"])
    track = rec["run_tracking_error_max"]
    out["tracking_error_bend_max_rad"] = float(max(track[0], track[2]))
    out["tracking_error_slide_max_m"] = float(max(track[1], track[3]))
    out["replay_settle_change"] = float(rec["run_replay_settle_change"])
    proj = rec["run_momentum_projection_sum"]
    out["momentum_projection_count"] = int(rec["run_momentum_projection_count"])
    out["momentum_projection_max_Nms"] = float(rec["run_momentum_projection_max"])
    # the signed drift the projection removed, per simulated second (the rotational part of
    # the free joint's momentum, about the bus centre, body Z = world Z in planar motion)
    out["angmom_drift_rate_unprojected_Nms_s"] = float(proj[5]) / max(result.t_end_s, 1e-300)
    out.update(momentum_yaw_error(sc, rec, yaw_end))
    out.update(actuation_summary(sc, rec))
    # exact model along the achieved shape path of one cycle of the last full-rate window
    out["theta_gamma_exact_achieved_rad"] = float("nan")
    N = int(rec["run_steps_per_cycle"])
    if "win_t" in rec and rec["win_t"].size:
        wid = rec["win_id"]
        last = wid == wid.max()
        wt, wq = rec["win_t"][last], rec["win_qpos"][last]
        k0 = np.rint(wt / cfg.sim.timestep_s).astype(np.int64)
        starts = np.flatnonzero(k0 % N == 0)
        if starts.size and starts[0] + N < wt.size and starts[0] >= 0:
            i0 = starts[0]
            qa = shape_indices(sc.model)["qpos"]
            seg = wq[i0 : i0 + N + 1]
            out["theta_gamma_exact_achieved_rad"] = float(
                exact_rotation_samples(sc.planar, seg[:, qa[0]], seg[:, qa[1]])[-1]
            )
    return out, series


@register_task("msac", "lumped")
class LumpedTask(MsacTask):
    """Analytic only: the references of the configured geometry; the runner takes no MuJoCo step."""

    def simulation(self) -> StaticRunner:
        self.runner = StaticRunner(self.model, self.path)
        return self.runner

    def summarise(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return {**self.references(), "simulated_time_s": 0.0, "wall_time_s": result.wall_time_s}, {}


@register_task("msac", "multibody")
class MultibodyTask(MsacTask):
    """The MuJoCo model driven along the cycle (native rollout or computed torque, ``drive.method``)."""

    overlay = ("yaw_unwrapped_rad", "phase")

    def simulation(self) -> MsacRunner:
        cfg, p = self.cfg, self.cfg.post
        self.runner = MsacRunner(
            model=self.model,
            path=self.path,
            duration_s=cfg.sim.duration_s,
            method=cfg.drive.method,
            record_every=cfg.sim.record_every,
            omega_c_dt=cfg.drive.omega_c_dt,
            calibration_cycles=cfg.drive.calibration_cycles,
            chunk_cycles=cfg.drive.chunk_cycles,
            window_s=p.window_s,
            omega_sample_hz=p.omega_sample_Hz,
            lowpass_order=p.lowpass_order,
            lowpass_cutoff_hz=p.lowpass_cutoff_Hz,
            checkpoint_every_s=cfg.sim.checkpoint_every_s,
            momentum_projection=cfg.drive.projection,
        )
        return self.runner

    def summarise(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return multibody_summary(self.msac, result, self.references())

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return msac_plots(
            run_dir,
            {**result.records, **series, "_summary": self.last_summary},
            cfg=self.cfg,
            path=self.path,
            model=self.model,
        )


@register_task("msac", "sweep")
class SweepTask(MsacTask):
    """Every point of ``[sweep]`` as a multibody run plus its references (:class:`SweepRunner`)."""

    def simulation(self) -> SweepRunner:
        self.runner = SweepRunner(self.cfg)
        return self.runner

    def summarise(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return self.runner.postprocess(result)

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        return [sweep_plot(self.cfg, run_dir, {**result.records, **series})]


def build_msac_scenario(cfg: MsacConfig) -> MsacTask:
    """Task object of an MSAC config: the class registered for ``("msac", cfg.scenario)``
    (:func:`magsail_mj.concepts.build_task`)."""
    return build_task(cfg)


@dataclass
class SweepRunner(WholeRun):
    """Runs every point of a ``[sweep]`` config ``cfg``: a :class:`MultibodyTask` of each point
    (:func:`magsail_mj.concepts.msac.config.point_config`) run through its own runner, then its
    summary.

    ``records`` hold the first point's ``t``/``qpos`` (so the run folder renders) and, per
    point, ``sweep_*`` arrays: the swept values, the per-cycle rotation from Eq. (6), the exact
    model and MuJoCo, the secular rates, the peak hinge torque and slide force, and the
    wall time.
    """

    cfg: MsacConfig

    def run_whole(self, *, progress: bool) -> RunResult:
        cfg = self.cfg
        sw = cfg.sweep
        wall0 = time.perf_counter()
        rows: list[dict[str, Any]] = []
        first = None
        steps = 0
        for values in sw.points:
            pc = point_config(cfg, sw.keys, values, cycles=sw.cycles, keep_steps_per_cycle=sw.keep_steps_per_cycle)
            sc = MultibodyTask(pc)
            res = sc.simulation().run(progress=False)
            if res.status != "completed":  # a point that went bad ends the sweep with its status
                if res.status == "interrupted":
                    raise KeyboardInterrupt(res.message)
                if first is None:
                    first = res
                return RunResult(
                    records=first.records,
                    status=res.status,
                    message=f"sweep point {dict(zip(sw.keys, values))}: {res.message}",
                    t_end_s=float(res.t_end_s),
                    steps=steps + res.steps,
                    wall_time_s=time.perf_counter() - wall0,
                )
            summ, _ = sc.postprocess(res)
            steps += res.steps
            if first is None:
                first = res
            rows.append(summ)
        keys = (
            "theta_gamma_eq6_model_rad",
            "theta_gamma_eq6_stretch_rad",
            "theta_gamma_exact_rad",
            "theta_gamma_mujoco_rad",
            "theta_gamma_mujoco_std_rad",
            "mujoco_vs_exact_rel_diff",
            "predicted_rate_lumped_rad_s",
            "predicted_rate_exact_rad_s",
            "secular_rate_rad_s",
            "hinge_torque_peak_Nm",
            "slide_force_peak_N",
            "angular_momentum_drift",
            "hinge_torque_rms_Nm",
            "slide_force_rms_N",
            "max_cycle_rate_Hz",
            "angmom_spurious_yaw_rel",
            "cycle_frequency_Hz",
            "timestep_s",
            "wall_time_s",
        )
        records = {"t": first.records["t"], "qpos": first.records["qpos"]}
        for k in keys:
            records[f"sweep_{k}"] = np.array([r[k] for r in rows], dtype=float)
        for j, key in enumerate(sw.keys):
            vals = [p[j] for p in sw.points]
            arr = np.array(vals, dtype=float)
            records[f"sweep_value_{j}"] = arr
        return RunResult(
            records=records,
            status="completed",
            message=f"{len(rows)} sweep points",
            t_end_s=float(first.t_end_s),
            steps=steps,
            wall_time_s=time.perf_counter() - wall0,
        )

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        rec, sw = result.records, self.cfg.sweep
        summ: dict[str, Any] = {
            "sweep_base": sw.base,
            "sweep_keys": list(sw.keys),
            "sweep_points": [list(p) for p in sw.points],
            "sweep_cycles": sw.cycles,
            "wall_time_s": result.wall_time_s,
        }
        for k, v in rec.items():
            if k.startswith("sweep_") and not k.startswith("sweep_value"):
                summ[k] = v.tolist()
        d = np.abs(rec["sweep_mujoco_vs_exact_rel_diff"])
        summ["sweep_mujoco_vs_exact_rel_diff_max"] = float(np.nanmax(d)) if d.size else float("nan")
        return summ, {}
