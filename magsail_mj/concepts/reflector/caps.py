r"""Case B3 of the reflector pitch scenario: the smallest torque cap that keeps the pitch error below
5° (and below 1°) throughout the run, for one areal density — one command runs the whole sweep.

Procedure: caps ``c_k = 0.25 · 2^(k/2)`` N m, ``k = 0 … 16`` (0.25 to 64 N m), each a full
Scenario B run (10 orbits) with the config's controller and saturation; then, for each
threshold θ ∈ {5°, 1°}, bisection (geometric midpoint) between the last failing and the first
passing cap until they differ by less than ``rel_tol`` (1 %). The reported cap is the passing
end of the final bracket (``None`` if even the largest cap fails, the smallest if it passes).

A run fails a threshold θ as soon as the attitude-error angle ``2 arccos|q_e,w|`` exceeds θ; the
run is then stopped there (a watchdog wrapped around the controller ends the step loop), which
saves most of the cost of failing caps. Monotonicity of the maximum error in the cap is assumed
(a larger cap never hurts this controller) and reported as checked on the sweep grid.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.divergence import DivergenceError, TrackingLost, check_inner_run
from magsail_mj.loads.body_torque import HeldBodyTorqueLoad
from magsail_mj.plotting import new_figure, save_figure
from magsail_mj.concepts.reflector.model import ReflectorModel
from magsail_mj.sim import RunResult, Simulation, WholeRun

__all__ = ["CapSweepRunner", "cap_grid", "caps_outputs", "caps_plots"]

DEG = math.pi / 180.0


def cap_grid(*, base_Nm: float = 0.25, k_max: int = 16) -> np.ndarray:
    """``0.25 · 2^(k/2)`` N m for ``k = 0 … k_max``."""
    return base_Nm * 2.0 ** (np.arange(k_max + 1) / 2.0)


class _Watchdog:
    """Wraps the pitch controller; raises when the error angle exceeds ``limit_rad``."""

    def __init__(self, inner, limit_rad: float) -> None:
        self.inner = inner
        self.period_s = inner.period_s
        self.limit = float(limit_rad)
        self.err_max = 0.0

    def update(self, state):
        cmd = self.inner.update(state)
        err = 2.0 * math.acos(min(1.0, abs(float(cmd.q_e[0]))))
        self.err_max = max(self.err_max, err)
        if err > self.limit:
            raise TrackingLost(
                f"tracking error {math.degrees(err):.3f}° above {math.degrees(self.limit):g}° at t = {state.t:.1f} s"
            )
        return cmd


@dataclass
class CapRun:
    cap_Nm: float
    limit_deg: float
    passed: bool
    err_max_rad: float
    t_stop_s: float
    wall_s: float


@dataclass
class CapSweepRunner(WholeRun):
    """Runs the B3 sweep (module docstring) and returns a :class:`RunResult` whose records are one
    row per run: ``t`` (run index), ``cap_Nm``, ``limit_deg``, ``passed``, ``err_max_rad``,
    ``t_stop_s``, ``wall_s``, and ``qpos`` (the initial state, for the run-folder contract).

    Every run is a :class:`magsail_mj.sim.Simulation` of ``plate`` (the built pitch model) with its
    pitch controller behind the watchdog; the runner has no step loop of its own."""

    plate: ReflectorModel
    thresholds_deg: tuple[float, ...] = (5.0, 1.0)
    rel_tol: float = 0.01

    def _init_state(self, data) -> None:
        self.plate.write_state(data, *self.plate.pitch_initial_state())

    def simulation(self, cap: float, limit_deg: float) -> tuple[Simulation, _Watchdog]:
        """One run of the sweep: cap ``cap`` [N m], stopped above ``limit_deg`` [deg]."""
        p = self.plate
        ctl = p.pitch_controller()
        ctl.cap = float(cap)
        dog = _Watchdog(ctl, limit_deg * DEG)
        sim = Simulation(
            model=p.model,
            duration_s=p.cfg.sim.duration_s,
            loads=[HeldBodyTorqueLoad(p.idx.plate)],
            controller=dog,
            probes={},
            record_every=10**9,
            init=self._init_state,
        )
        return sim, dog

    def _one(self, cap: float, limit_deg: float) -> CapRun:
        sim, dog = self.simulation(cap, limit_deg)
        t0 = time.perf_counter()
        res = sim.run()
        check_inner_run(res.status, res.message, where=f"cap {cap:g} N m, limit {limit_deg:g}°")
        return CapRun(
            cap_Nm=float(cap),
            limit_deg=limit_deg,
            passed=res.status == "completed",
            err_max_rad=dog.err_max,
            t_stop_s=res.t_end_s,
            wall_s=time.perf_counter() - t0,
        )

    def _search(self, runs: list[CapRun], *, progress: bool) -> None:
        """The grid, then a bisection per threshold; appends every run to ``runs``."""
        hi_thr = max(self.thresholds_deg)
        grid = cap_grid()
        # grid sweep with the loosest watchdog: every run yields err_max for all thresholds
        for cap in grid:
            runs.append(self._one(cap, hi_thr))
            if progress:
                r = runs[-1]
                print(
                    f"cap {cap:8.4g} N m: {'pass' if r.passed else 'fail'} {math.degrees(r.err_max_rad):.3f}°",
                    flush=True,
                )
        for thr in sorted(self.thresholds_deg, reverse=True):

            def ok(r: CapRun) -> bool:
                return r.passed and r.err_max_rad <= thr * DEG

            grid_runs = runs[: grid.size]
            flags = [ok(r) for r in grid_runs]
            if not any(flags):
                self.minimum[thr] = None
                continue
            first = flags.index(True)
            if first == 0:
                self.minimum[thr] = float(grid[0])
                continue
            lo, hi = float(grid[first - 1]), float(grid[first])
            while hi / lo - 1.0 > self.rel_tol:
                mid = math.sqrt(lo * hi)
                r = self._one(mid, thr)
                runs.append(r)
                if ok(r):
                    hi = mid
                else:
                    lo = mid
            self.minimum[thr] = hi

    def run_whole(self, *, progress: bool) -> RunResult:
        wall0 = time.perf_counter()
        runs: list[CapRun] = []
        grid = cap_grid()
        self.minimum: dict[float, float | None] = {}
        status, message = "completed", ""
        try:
            self._search(runs, progress=progress)
        except DivergenceError as err:
            status, message = "diverged", str(err)
        self.runs = runs
        self.monotonic = {
            thr: bool(np.all(np.diff([float(r.passed and r.err_max_rad <= thr * DEG) for r in runs[: grid.size]]) >= 0))
            for thr in self.thresholds_deg
        }
        q0, _ = self.plate.pitch_initial_state()
        data_qpos = self.plate.qpos_rows(q0, len(runs))
        rec = {
            "t": np.arange(len(runs), dtype=float),
            "qpos": data_qpos,
            "cap_Nm": np.array([r.cap_Nm for r in runs]),
            "limit_deg": np.array([r.limit_deg for r in runs]),
            "passed": np.array([r.passed for r in runs], dtype=np.int8),
            "err_max_rad": np.array([r.err_max_rad for r in runs]),
            "t_stop_s": np.array([r.t_stop_s for r in runs]),
            "wall_s": np.array([r.wall_s for r in runs]),
        }
        message = message or f"B3 cap sweep: {len(runs)} runs"
        return RunResult(
            records=rec,
            status=status,
            message=message,
            t_end_s=float(self.plate.cfg.sim.duration_s),
            steps=0,
            wall_time_s=time.perf_counter() - wall0,
        )


def caps_outputs(runner: CapSweepRunner, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary of a B3 sweep: ``cap_min_err_below_5deg_Nm``, ``cap_min_err_below_1deg_Nm`` and the run table."""
    p = runner.plate
    cfg = p.cfg
    rec = result.records
    summary: dict[str, Any] = {
        "status": result.status,
        "wall_time_s": result.wall_time_s,
        "runs": int(rec["t"].size),
        "areal_density_kg_m2": cfg.plate.areal_density_kg_m2,
        "variant": cfg.variant,
        "rate_term": cfg.control.rate_term,
        "saturation": cfg.control.saturation_mode,
        "orbit_period_s": p.orbit.period_s,
        "t_mid_s": p.orbit.t_mid_s,
        "cap_geometric_Nm": p.cap.T_max_ycoil_Nm,
        "cap_min_err_below_5deg_Nm": runner.minimum.get(5.0),
        "cap_min_err_below_1deg_Nm": runner.minimum.get(1.0),
        "grid_monotonic_5deg": runner.monotonic.get(5.0),
        "grid_monotonic_1deg": runner.monotonic.get(1.0),
        "bisection_rel_tol": runner.rel_tol,
    }
    series = {"cap_Nm": rec["cap_Nm"], "err_max_deg": np.degrees(rec["err_max_rad"])}
    return summary, series


def caps_plots(
    run_dir: Path,
    *,
    runs: list[CapRun],
    minimum: dict[float, float | None],
    T_max_Nm: float,
    areal_density_kg_m2: float,
) -> list[Path]:
    """``caps.png``: maximum error [deg] (up to the stop) against the cap [N m], pass/fail, the
    thresholds, the minimum caps found and the geometric coil capability ``T_max_Nm``."""
    fig, ax = new_figure(figsize=(8, 4.5))
    for r in runs:
        ax.loglog(
            r.cap_Nm,
            max(math.degrees(r.err_max_rad), 1e-4),
            "o" if r.passed else "x",
            color="C2" if r.passed else "C3",
            ms=5,
        )
    for thr in (5.0, 1.0):
        ax.axhline(thr, color="k", ls="--", lw=0.8)
        c = minimum.get(thr)
        if c is not None:
            ax.axvline(c, color="C0", ls=":", lw=1.0)
            ax.text(c, thr * 1.15, f" {c:.3g} N m", color="C0", fontsize=8)
    ax.axvline(T_max_Nm, color="C1", lw=1.0, label=f"coil T_max {T_max_Nm:.3g} N m")
    ax.set_xlabel("torque cap [N m]"), ax.set_ylabel("max attitude error up to the stop [deg]")
    ax.set_title(f"B3 cap sweep, σ = {1e3 * areal_density_kg_m2:g} g/m² (o pass, x stopped)")
    ax.grid(alpha=0.3, which="both"), ax.legend()
    return [save_figure(fig, Path(run_dir) / "caps.png")]
