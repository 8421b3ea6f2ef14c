"""Disturbance torques on CNUSAIL-1 over one orbit, body held exactly in the nadir and in the
deorbit attitude (Yoo et al. 2016, Eqs. 12–23): gravity gradient, drag, SRP, residual dipole.

    python scripts/cnusail_disturbances.py [--config magsail_mj/concepts/cnusail/configs/nadir_post.toml] [--out runs/cnusail/disturbances]

No attitude simulation: the environment of the config (J2 orbit, IGRF, Sun, exponential
atmosphere) is sampled along one orbit and the disturbance load is evaluated at the two commanded
attitudes. Writes ``disturbances_orbit.png`` and ``disturbances_orbit.json`` (peak |T| per source
and mode) and prints the peaks.
"""  # noqa: E501

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import magsail_mj
from magsail_mj.io import write_json
from magsail_mj.concepts.cnusail.disturbances import SOURCES
from magsail_mj.plotting import save_figure
from magsail_mj.concepts.cnusail.metrics import disturbance_orbit_profile
from magsail_mj.concepts.cnusail.plots import disturbance_orbit_figure

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--config", default=str(ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "nadir_post.toml")
    )  # noqa: E501
    ap.add_argument("--out", default=str(ROOT / "runs" / "cnusail" / "disturbances"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--samples", type=int, default=1200)
    args = ap.parse_args(argv)
    sim = magsail_mj.load(args.config, args.set)
    sc, cfg = sim.scenario, sim.cfg
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    series, peaks = {}, {}
    for mode in ("nadir", "deorbit"):
        ts, tq = disturbance_orbit_profile(sc, mode, n=args.samples)
        series[f"dist_orbit_t_{mode}_s"], series[f"dist_orbit_{mode}_Nm"] = ts, tq
        series[f"dist_orbit_{mode}_gg_5deg_Nm"] = disturbance_orbit_profile(sc, mode, n=200, offset_deg=5.0)[1][:, 0]
        series[f"dist_orbit_t_{mode}_gg_5deg_s"] = np.linspace(0.0, ts[-1], 200)
        peaks[f"gravity_gradient_5deg_off_max_{mode}_Nm"] = float(
            np.max(np.linalg.norm(series[f"dist_orbit_{mode}_gg_5deg_Nm"], axis=1))
        )
        for k, src in enumerate(SOURCES):
            peaks[f"{src}_max_{mode}_Nm"] = float(np.max(np.linalg.norm(tq[:, k], axis=1)))
    save_figure(
        disturbance_orbit_figure(
            series, sc.orbit_period_s, f"CNUSAIL-1 {cfg.spacecraft.configuration}: disturbance torques over one orbit"
        ),
        out / "disturbances_orbit.png",
    )
    write_json(out / "disturbances_orbit.json", peaks)
    print(json.dumps(peaks, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
