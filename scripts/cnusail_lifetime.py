"""Orbital lifetime of CNUSAIL-1 (Yoo et al. 2016) for nadir pointing, deorbit attitude and
random tumbling; Cowell and orbit-averaged propagation; exponential and NRLMSISE-00 atmospheres.

    python scripts/cnusail_lifetime.py [--out runs/cnusail/lifetime] [--set lifetime.atmospheres='["exp"]']

Same as ``magsail run magsail_mj/concepts/cnusail/configs/lifetime.toml --out runs/cnusail/lifetime``; prints the
lifetime table (days). The MSIS cases need ``pip install 'magsail_mj[msis]'`` (skipped otherwise).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import magsail_mj  # noqa: F401  (chooses the GL backend before mujoco is imported)
from magsail_mj.config import load_config
from magsail_mj.run import run_scenario

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "runs" / "cnusail" / "lifetime"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    cfg = load_config(ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "lifetime.toml", args.set)
    out = run_scenario(cfg, args.out, overwrite=True, progress=False)
    with open(out.run_dir / "lifetime_table.csv") as fh:
        rows = list(csv.DictReader(fh))
    print(f"{'regime':10s} {'method':9s} {'atmosphere':10s} {'lifetime [days]':>16s}")
    for r in rows:
        flag = " (cap: lower bound)" if r["reached_cap"] == "True" else ""
        print(f"{r['regime']:10s} {r['method']:9s} {r['atmosphere']:10s} {float(r['lifetime_days']):16.1f}{flag}")
    for k in sorted(out):
        if k.startswith("cowell_vs_averaged") or k.startswith("reference_") or k == "notes":
            print(f"{k} = {out[k]}")
    print(f"run folder: {out.run_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
