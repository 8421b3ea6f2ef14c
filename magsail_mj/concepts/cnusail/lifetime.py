r"""CNUSAIL scenario S8: orbital lifetime for the three attitude regimes, as a scenario.

There is no MuJoCo integration: :meth:`LifetimeTask.simulation` returns a
:class:`LifetimeRunner` (the same ``run()`` → :class:`magsail_mj.sim.RunResult` interface as
:class:`magsail_mj.sim.Simulation`, no time steps of its own) whose ``run`` calls the SciPy
propagators of :mod:`magsail_mj.concepts.cnusail.orbit_decay` (Cowell for the regimes
in ``lifetime.methods_cowell``, orbit-averaged for every regime) for every atmosphere in
``lifetime.atmospheres`` (the MSIS cases are skipped, with a note in the summary, when pymsis is not
installed), plus the comparison set: generic 3U cubesats in circular orbits and the flown sail
cubesats NanoSail-D2 and LightSail-1 (approximate public data). ``sim.duration_s`` caps
the averaged runs (a run that reaches it reports a lower bound), ``lifetime.cowell_max_days`` the
Cowell runs. The MJCF written for this config is the deployed cubesat (the spacecraft whose
lifetime is computed); it is not simulated.

Outputs: ``summary.json`` with ``lifetime_{regime}_{method}_{atm}_s`` and ``…_days`` (regime ∈
nadir, deorbit, tumbling; method ∈ cowell, averaged; atm ∈ exp, msis_low, msis_mid, msis_high),
``lifetime_{regime}_days`` (Cowell where run, else averaged; exponential atmosphere),
``cowell_vs_averaged_{regime}_{atm}_rel_diff``; ``lifetime_table.csv``; ``comparison.json``;
``timeseries.zarr`` with each run's time, mean-altitude, perigee and apogee series; the plots
``altitude_decay.png`` and ``lifetime_comparison.png``.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import mujoco
import numpy as np

from magsail_mj.concepts.cnusail.orbit_decay import (
    DecayResult,
    averaged_decay,
    cowell_decay,
    density_model,
    geometric_mean_elements,
)
from magsail_mj.concepts import register_task
from magsail_mj.environment.environment import elements_from_config
from magsail_mj.environment.timeutil import julian_date, parse_epoch
from magsail_mj.io import atomic_path, write_json
from magsail_mj.concepts.cnusail.mjcf import build_cubesat_spec
from magsail_mj.concepts.cnusail.config import CnusailConfig
from magsail_mj.concepts.cnusail.model import model_params
from magsail_mj.concepts.cnusail.plots import lifetime_plots
from magsail_mj.sim import RunResult, WholeRun

__all__ = ["LifetimeTask", "LifetimeRunner", "REFERENCE_SAILS"]

DAY = 86400.0
REFERENCE_SAILS: tuple[dict[str, Any], ...] = (
    # approximate public data: NanoSail-D2 ejected Jan 2011 near 600–650 km, re-entered
    # Sept 2011 (≈ 240 days); LightSail-1 in a 356 × 705 km orbit, re-entered about a week after
    # its sail deployment. The model prediction takes the random-tumbling area A_s/2.
    {
        "name": "NanoSail-D2",
        "mass_kg": 4.0,
        "sail_area_m2": 10.0,
        "perigee_km": 625.0,
        "apogee_km": 625.0,
        "observed_days": 240.0,
    },
    {
        "name": "LightSail-1",
        "mass_kg": 5.0,
        "sail_area_m2": 32.0,
        "perigee_km": 356.0,
        "apogee_km": 705.0,
        "observed_days": 7.0,
    },
)


def _timed(decay: Callable[..., DecayResult], **options: Any) -> tuple[DecayResult, float]:
    """``(decay(**options), wall time of the call [s])``."""
    t0 = time.perf_counter()
    return decay(**options), time.perf_counter() - t0


@dataclass
class LifetimeRunner(WholeRun):
    """The runner of a lifetime task: ``run`` does the analysis (:meth:`LifetimeTask.compute`) and
    returns its records as a :class:`magsail_mj.sim.RunResult` (``status`` ``"diverged"`` when a
    propagation produced a non-finite number)."""

    sc: LifetimeTask

    def run_whole(self, *, progress: bool) -> RunResult:
        t0 = time.perf_counter()
        records = self.sc.compute()
        wall = time.perf_counter() - t0
        status, message = "completed", ""
        bad = [k for k, v in records.items() if np.asarray(v).dtype.kind == "f" and not np.isfinite(v).all()]
        if bad:  # the same rule as every runner: a non-finite number is a divergence, never a result
            status, message = "diverged", f"decay propagation produced non-finite values in {', '.join(bad)}"
        return RunResult(
            records=records,
            status=status,
            message=message,
            t_end_s=float(records["t"][-1]),
            steps=self.sc.n_runs,
            wall_time_s=wall,
        )


@register_task("cnusail", "lifetime")
@dataclass
class LifetimeTask:
    """The S8 analysis of a ``kind = "lifetime"`` CNUSAIL config (module docstring)."""

    cfg: CnusailConfig
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        self.spec = build_cubesat_spec(model_params(self.cfg))
        o = self.cfg.orbit
        self.epoch = parse_epoch(o.epoch)
        self.elements = elements_from_config(o, jd0=julian_date(self.epoch))
        self.R_E = o.R_E_km * 1e3
        self.mu = o.mu_m3_s2
        self.table: list[dict[str, Any]] = []
        self.comparison: dict[str, Any] = {}
        self.notes: list[str] = []
        self.n_runs = 0

    def simulation(self) -> LifetimeRunner:
        return LifetimeRunner(self)

    # -------------------------------------------------------------- analysis
    def _areas(self) -> dict[str, float]:
        L = self.cfg.lifetime
        return {"nadir": L.area_nadir_m2, "deorbit": L.area_deorbit_m2, "tumbling": L.area_tumbling_m2}

    def _bstar(self, area: float, mass: float | None = None) -> float:
        return self.cfg.drag.drag_coefficient * area / (mass or self.cfg.spacecraft.mass_kg)

    def _averaged(self, rho_fn: Any, *, a0_m: float, e0: float, bstar: float) -> DecayResult:
        """An averaged decay (:func:`averaged_decay`, counted in ``n_runs``) from ``a0_m`` [m] and ``e0``
        in the density model ``rho_fn`` down to ``lifetime.stop_altitude_km``, capped at ``sim.duration_s``."""
        res = averaged_decay(
            a0_m=a0_m,
            e0=e0,
            bstar=bstar,
            rho_fn=rho_fn,
            R_E=self.R_E,
            stop_alt_m=self.cfg.lifetime.stop_altitude_km * 1e3,
            t_max_s=self.cfg.sim.duration_s,
            mu=self.mu,
        )
        self.n_runs += 1
        return res

    def compute(self) -> dict[str, np.ndarray]:
        """Run every decay propagation; returns the records (time, mean-altitude, perigee and apogee
        series of each run [s, m]) and fills ``table``, ``comparison`` and ``notes``."""
        cfg, L = self.cfg, self.cfg.lifetime
        stop = L.stop_altitude_km * 1e3
        el = self.elements
        if L.averaged_init == "geometric" and cfg.orbit.propagator == "j2":
            a0, e0 = geometric_mean_elements(el, mu=self.mu, J2=cfg.orbit.J2, R_j2=cfg.orbit.j2_radius_km * 1e3)
        else:
            a0, e0 = el.a, el.e
        self.mean_elements = (a0, e0)
        records: dict[str, np.ndarray] = {}
        rho_exp = None
        for atm in L.atmospheres:
            try:
                rho = density_model(atm, epoch=self.epoch)
            except ImportError as err:
                self.notes.append(f"{atm}: skipped ({err})")
                continue
            if atm == "exp":
                rho_exp = rho
            for reg, area in self._areas().items():
                b = self._bstar(area)
                common = {"bstar": b, "rho_fn": rho, "R_E": self.R_E, "stop_alt_m": stop, "mu": self.mu}
                runs = [_timed(averaged_decay, a0_m=a0, e0=e0, t_max_s=cfg.sim.duration_s, **common)]
                if reg in L.methods_cowell:
                    runs.append(
                        _timed(
                            cowell_decay,
                            elements=el,
                            t_max_s=L.cowell_max_days * DAY,
                            j2=cfg.orbit.propagator == "j2",
                            J2=cfg.orbit.J2,
                            R_j2=cfg.orbit.j2_radius_km * 1e3,
                            corotating=L.cowell_corotating,
                            omega_earth=cfg.orbit.omega_earth_rad_s,
                            rtol=L.cowell_rtol,
                            **common,
                        )
                    )
                for res, wall in runs:
                    self.n_runs += 1
                    key = f"{reg}_{res.method}_{atm}"
                    records[f"t_{key}_s"] = res.t_s
                    records[f"a_alt_{key}_m"] = res.a_m - self.R_E
                    records[f"perigee_{key}_m"] = res.perigee_alt_m
                    records[f"apogee_{key}_m"] = res.apogee_alt_m
                    self.table.append(
                        {
                            "regime": reg,
                            "method": res.method,
                            "atmosphere": atm,
                            "area_m2": area,
                            "bstar_m2_kg": b,
                            "lifetime_s": res.lifetime_s,
                            "lifetime_days": res.lifetime_days,
                            "reached_cap": res.reached_cap,
                            "rhs_evaluations": res.n_rhs,
                            "wall_s": wall,
                        }
                    )
        # comparison chart (exponential atmosphere)
        if rho_exp is not None:
            gen_days, gen_cap = [], []
            for h in L.generic_altitudes_km:
                a = self.R_E + h * 1e3
                r = self._averaged(rho_exp, a0_m=a, e0=0.0, bstar=self._bstar(L.generic_area_m2))
                gen_days.append(r.lifetime_days)
                gen_cap.append(r.reached_cap)
            self.comparison["generic"] = {
                "altitude_km": list(L.generic_altitudes_km),
                "lifetime_days": gen_days,
                "reached_cap": gen_cap,
                "area_m2": L.generic_area_m2,
                "mass_kg": cfg.spacecraft.mass_kg,
            }
            rows = []
            for row in self.table:
                if row["atmosphere"] != "exp":
                    continue
                if row["method"] == "averaged" and any(
                    r["regime"] == row["regime"] and r["method"] == "cowell" and r["atmosphere"] == "exp"
                    for r in self.table
                ):
                    continue
                rows.append(
                    {
                        "regime": row["regime"],
                        "method": row["method"],
                        "lifetime_days": row["lifetime_days"],
                        "mean_alt_km": (a0 - self.R_E) / 1e3,
                        "perigee_km": (a0 * (1 - e0) - self.R_E) / 1e3,
                        "apogee_km": (a0 * (1 + e0) - self.R_E) / 1e3,
                    }
                )
            self.comparison["cnusail"] = rows
            refs = []
            if L.references:
                for ref in REFERENCE_SAILS:
                    rp, ra = self.R_E + ref["perigee_km"] * 1e3, self.R_E + ref["apogee_km"] * 1e3
                    r = self._averaged(
                        rho_exp,
                        a0_m=0.5 * (rp + ra),
                        e0=(ra - rp) / (ra + rp),
                        bstar=self._bstar(ref["sail_area_m2"] / 2.0, ref["mass_kg"]),
                    )
                    refs.append(
                        {
                            **ref,
                            "altitude_km": 0.5 * (ref["perigee_km"] + ref["apogee_km"]),
                            "predicted_days": r.lifetime_days,
                        }
                    )
            self.comparison["references"] = refs
        base = "nadir_averaged_exp"
        records["t"] = records.get(f"t_{base}_s", np.array([0.0]))
        return records

    # -------------------------------------------------------------- outputs
    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        s: dict[str, Any] = {
            "status": result.status,
            "wall_time_s": result.wall_time_s,
            "decay_runs": self.n_runs,
            "orbit_semi_major_axis_m": self.elements.a,
            "orbit_eccentricity": self.elements.e,
            "mean_semi_major_axis_m": self.mean_elements[0],
            "mean_eccentricity": self.mean_elements[1],
            "stop_altitude_m": self.cfg.lifetime.stop_altitude_km * 1e3,
        }
        for row in self.table:
            key = f"lifetime_{row['regime']}_{row['method']}_{row['atmosphere']}"
            s[f"{key}_s"] = row["lifetime_s"]
            s[f"{key}_days"] = row["lifetime_days"]
            if row["reached_cap"]:
                s[f"{key}_is_lower_bound"] = True
        for reg in ("nadir", "deorbit", "tumbling"):
            for m in ("cowell", "averaged"):
                v = s.get(f"lifetime_{reg}_{m}_exp_days")
                if v is not None:
                    s[f"lifetime_{reg}_days"] = v
                    break
            for atm in self.cfg.lifetime.atmospheres:
                c, a = s.get(f"lifetime_{reg}_cowell_{atm}_s"), s.get(f"lifetime_{reg}_averaged_{atm}_s")
                if c is not None and a is not None:
                    s[f"cowell_vs_averaged_{reg}_{atm}_rel_diff"] = (a - c) / c
        for ref in self.comparison.get("references", []):
            nm = ref["name"].lower().replace("-", "").replace(" ", "_")
            s[f"reference_{nm}_predicted_days"] = ref["predicted_days"]
            s[f"reference_{nm}_observed_days"] = ref["observed_days"]
        if self.notes:
            s["notes"] = "; ".join(self.notes)
        return s, {}

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        out = []
        path = run_dir / "lifetime_table.csv"
        with atomic_path(path, suffix=".csv") as tmp:
            with open(tmp, "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(self.table[0]) if self.table else ["regime"])
                w.writeheader()
                for row in self.table:
                    w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
        out.append(path)
        out.append(write_json(run_dir / "comparison.json", self.comparison))
        out += lifetime_plots(run_dir, result.records, self.table, self.comparison, "CNUSAIL-1")
        return out

    def render_info(self) -> dict[str, Any]:
        return {
            "title": "CNUSAIL-1 lifetime (no attitude simulation)",
            "overlay": [],
            "video": "the lifetime analysis propagates orbits only; it has no motion to render",
        }

    def manifest_extra(self) -> dict[str, Any]:
        return {"kind": "lifetime", "runs": self.n_runs, "notes": self.notes}
