"""Start-up times of the ``magsail`` command and the heavy modules each form imports.

    .venv/bin/python scripts/bench_startup.py [--repeat 5] [--config CONFIG.toml]

Starts ``python -m magsail_mj`` with ``--help``, ``--version`` and ``validate CONFIG`` (and
``python -c "import magsail_mj"``) ``--repeat`` times each, and prints one JSON object: per form the
median and the smallest wall time [s] and the heavy packages it imported (Dask, Matplotlib, mediapy,
MuJoCo, NumPy, pydantic, SciPy, xarray, Zarr). The command answers ``--help`` and ``--version`` from
the standard library alone (:mod:`magsail_mj.cli`); ``tests/test_cli_startup.py`` checks the imports.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("dask", "distributed", "matplotlib", "mediapy", "mujoco", "numpy", "pydantic", "scipy", "xarray", "zarr")
DEFAULT_CONFIG = "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"
_PROBE = """
import atexit, sys
atexit.register(lambda: print("MODULES " + " ".join(sorted({m.split('.')[0] for m in sys.modules})), file=sys.stderr))
if sys.argv[1:] == ["--import"]:
    import magsail_mj
    sys.exit(0)
from magsail_mj.entry import main
sys.argv = ["magsail", *sys.argv[1:]]
sys.exit(main())
"""


def _time(argv: list[str]) -> float:
    """Wall time [s] of ``python -m magsail_mj ARGV`` (or of the package import for ``--import``)."""
    command = (
        [sys.executable, "-c", "import magsail_mj"]
        if argv == ["--import"]
        else [sys.executable, "-m", "magsail_mj", *argv]
    )
    t0 = time.perf_counter()
    subprocess.run(command, cwd=ROOT, capture_output=True, check=False)
    return time.perf_counter() - t0


def _heavy(argv: list[str]) -> list[str]:
    """The heavy packages the form imports (read in the process at its exit)."""
    proc = subprocess.run([sys.executable, "-c", _PROBE, *argv], cwd=ROOT, capture_output=True, text=True, check=False)
    line = next((x for x in proc.stderr.splitlines() if x.startswith("MODULES ")), "MODULES ")
    return sorted(set(line.split()[1:]) & set(HEAVY))


def main(argv: list[str] | None = None) -> int:
    """Print the start-up report (one JSON object); 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="starts per form (default 5)")
    parser.add_argument(
        "--config", default=DEFAULT_CONFIG, help=f"config of the validate form (default {DEFAULT_CONFIG})"
    )
    args = parser.parse_args(argv)
    forms = {
        "import magsail_mj": ["--import"],
        "magsail --help": ["--help"],
        "magsail --version": ["--version"],
        "magsail validate": ["validate", args.config],
    }
    report = {}
    for name, form in forms.items():
        times = [_time(form) for _ in range(max(1, args.repeat))]
        report[name] = {
            "median_s": round(statistics.median(times), 3),
            "min_s": round(min(times), 3),
            "heavy_imports": _heavy(form),
        }
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
