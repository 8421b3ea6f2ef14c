"""Time of the first modes of a large strut structure (:func:`magsail_mj.structure.modes.structure_modes`).

    .venv/bin/python scripts/bench_structure_modes.py [--units 99] [--side-m 75] [--count 10]

Builds the two-layer lattice of ``--units`` cubes per side (99: 20 000 nodes, 60 000 coordinates,
~99 000 struts) as a strut :class:`~magsail_mj.structure.model.Structure` (uniform masses, equal
EA), and prints one JSON object: the sizes, the seconds to build the structure, to assemble the
sparse K and M, and to solve for the ``--count`` lowest elastic modes (plus the six rigid ones) by
shift-invert ``eigsh``, the peak resident memory, and the frequencies found.
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np

from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.structure.assembly import assemble
from magsail_mj.structure.generators.plates import lattice_structure
from magsail_mj.structure.modes import structure_modes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=99, help="cubes per side (default 99: 20 000 nodes)")
    parser.add_argument("--side-m", type=float, default=75.0, help="plate side [m] (default 75)")
    parser.add_argument("--count", type=int, default=10, help="elastic modes (default 10)")
    args = parser.parse_args()

    t0 = time.perf_counter()
    lat = make_lattice(units=args.units, side_m=args.side_m)
    structure = lattice_structure(
        lat, masses_kg=np.full(lat.n_nodes, 200.0 / lat.n_nodes), EA_N=1e5, damping_Ns_m=0.0, name="bench"
    )
    t1 = time.perf_counter()
    assembly = assemble(structure)
    t2 = time.perf_counter()
    result = structure_modes(structure, k=args.count + 6, assembly=assembly)
    t3 = time.perf_counter()
    print(
        json.dumps(
            {
                "nodes": lat.n_nodes,
                "struts": lat.n_struts,
                "n_dof": assembly.n_dof,
                "build_s": round(t1 - t0, 3),
                "assemble_s": round(t2 - t1, 3),
                "solve_s": round(t3 - t2, 3),
                "total_s": round(t3 - t0, 3),
                "peak_rss_MB": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1),
                "solver": result.solver,
                "zero_modes": result.n_zero,
                "frequencies_Hz": result.frequencies_Hz.tolist(),
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
