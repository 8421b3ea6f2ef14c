"""A structure file to its first MuJoCo step at 2 048, 8 192 and 20 000 nodes: each stage's time,
its growth per node, and the peak memory against the estimate.

For each size (square plate lattices of ``units`` cubes a side, two layers: ``2 (units + 1)²``
nodes, struts only) the plate is written as a structure file with an ``.npz`` companion
(:func:`~magsail_mj.structure.fileformat.write_structure`, not timed), then a fresh process runs
and times each stage of the path once:

* ``read`` — :func:`~magsail_mj.structure.fileformat.read_structure` (TOML, the ``.npz`` arrays,
  and the checks it runs itself);
* ``check`` — :func:`~magsail_mj.structure.checks.check_structure` again, on its own;
* ``build`` — :func:`~magsail_mj.structure.mjcf.build_structure_spec` (Euler, with
  ``--strut-elements``: ``auto`` by default, which builds the struts as 1-D flex edges above
  ``FLEX_AUTO_TENDON_DOFS``, i.e. the 8 192- and 20 000-node plates, and as tendons below);
* ``compile`` — ``spec.compile()``;
* ``data`` — ``mujoco.MjData(model)``;
* ``step`` — the first ``mujoco.mj_step``.

``index`` (:class:`~magsail_mj.structure.mjcf.StructureModelIndex`) is timed after them and is not
in ``total_s``; nor is ``compile_without_tendons_s``, the compile of the same plate without its
members (nodes only), which splits ``compile`` into MuJoCo's part that grows with the members
and the rest: ``member_compile_us_per_member`` is the difference over the member count (constant
when that part is linear, as with flex edges), ``tendon_compile_ns_per_tendon_dof`` the same over
``ntendon · nv`` (constant when it is ``O(ntendon nv)``, as MuJoCo's per-tendon
``tendon_invweight0`` over dense ``nv``-vectors is; ``null`` without tendons). The rest, MuJoCo's
compile of the bodies alone, is itself slightly superlinear (``mj_makeBSparse``,
``mj_validateReferences``: 0.15 s at 2 048 nodes, 5 s at 20 000 measured).

The process reports its peak resident set (``ru_maxrss``: MuJoCo's C
allocations included, which ``tracemalloc`` does not see) and the resident set it had before the
read (the interpreter and the imports): their difference is the path's own memory, compared with
:func:`~magsail_mj.resources.structure_model_bytes` of the plate's node and member counts; so is
MuJoCo's own part, ``MjModel.nbuffer + MjData.nbuffer + narena``.

The JSON object printed holds, per size, the counts and those figures; ``per_node_ratio``: per
stage, the time per node of each size over that of the smallest (1 for a stage whose cost grows
linearly with the node count), and ``largest``: the largest size's ``total_s`` with the stage
shares. ``load_average`` is ``os.getloadavg()`` before and after: the machine may be shared,
and timings are wall-clock; compare ratios measured in one call.

Measured (MuJoCo 4.0.0, a shared 2-core machine, load 1–4): the 20 000-node plate (89 002 struts,
``nv`` = 60 000) goes from file to first step in 11.3 s with flex struts (build 6.1 s, compile 4.8 s
of which 3.5 s are the bodies alone; ``--strut-elements flex``) and 18.4 s under a heavier load (the
default, ``auto``, builds the same flexes); at load 4–5, 14.4 s with flexes (compile 6.1 s) against
52.0 s as tendons (``--strut-elements tendons``: compile 40.0 s, 6.5 ns per tendon and dof, the
bodies 5.1 s of it); its peak resident set is 0.43 of
:func:`~magsail_mj.resources.structure_model_bytes`. With flexes at every size the total per node is
1.0, 0.95 and 1.58 times the 2 048-node plate's at 8 192 and 20 000 nodes (build 0.87, 1.24; compile
1.27, 2.91, dominated by the bodies' compile, 0.93, 2.49): the struts no longer make the compile
quadratic, MuJoCo's compile of the bodies remains slightly superlinear. The 2 048-node plate
compiles in 0.64 s as tendons (9.3 ns per tendon and dof), 0.17 s as flexes.

    .venv/bin/python scripts/bench_structure_scale.py                 # units 31, 63, 99
    .venv/bin/python scripts/bench_structure_scale.py --units 15 31
    .venv/bin/python scripts/bench_structure_scale.py --strut-elements flex     # every size flex
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import magsail_mj  # noqa: F401  (chooses the GL backend before MuJoCo is imported)
import mujoco
import numpy as np

from magsail_mj.resources import structure_model_bytes
from magsail_mj.structure.checks import check_structure
from magsail_mj.structure.fileformat import read_structure, write_structure
from magsail_mj.structure.generators import square_plate_lattice
from magsail_mj.structure.mjcf import STRUT_ELEMENTS, StructureModelIndex, build_structure_spec
from magsail_mj.structure.model import Members, Structure

STAGES = ("read", "check", "build", "compile", "data", "step")
DEFAULT_UNITS = (31, 63, 99)
SIDE_M, EA_N, MASS_KG, ZETA = 100.0, 1.0e6, 100.0, 0.01
TIMESTEP_S = 1e-3


def write_plate(units: int, folder: Path) -> Path:
    """The plate of ``units`` cubes a side as ``plate_<units>.toml`` with its ``.npz`` companion."""
    plate = square_plate_lattice(units=units, side_m=SIDE_M, EA_N=EA_N, total_mass_kg=MASS_KG, zeta_strut=ZETA)
    path = folder / f"plate_{units}.toml"
    write_structure(plate, path, arrays="npz")
    return path


def _rss_mb() -> float:
    """The process's resident set now [MiB] (``/proc/self/statm``)."""
    with open("/proc/self/statm") as stream:
        return int(stream.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _without_members(structure: Structure) -> Structure:
    """``structure``'s nodes alone (no members, no member sets)."""
    none = np.zeros(structure.n_members, dtype=bool)
    members = Members(**{f.name: getattr(structure.members, f.name)[none] for f in dataclasses.fields(Members)})
    return dataclasses.replace(structure, members=members, member_sets={})


def run_path(path: Path, strut_elements: str = "auto") -> dict:
    """Time each stage of the path for the structure file ``path`` (in this process), struts
    built as ``strut_elements``."""
    start_rss_mb = _rss_mb()
    seconds: dict[str, float] = {}

    def timed(stage: str, call):
        t0 = time.perf_counter()
        out = call()
        seconds[stage] = time.perf_counter() - t0
        return out

    structure = timed("read", lambda: read_structure(path).structure)
    timed("check", lambda: check_structure(structure))
    spec = timed(
        "build",
        lambda: build_structure_spec(
            structure, timestep_s=TIMESTEP_S, integrator="Euler", strut_elements=strut_elements
        ),
    )
    model = timed("compile", spec.compile)
    data = timed("data", lambda: mujoco.MjData(model))
    timed("step", lambda: mujoco.mj_step(model, data))
    t0 = time.perf_counter()
    StructureModelIndex.from_model(model, structure)
    index_s = time.perf_counter() - t0
    peak_rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    bare = build_structure_spec(_without_members(structure), timestep_s=TIMESTEP_S, integrator="Euler")
    t0 = time.perf_counter()
    bare.compile()
    bare_compile_s = time.perf_counter() - t0
    estimate = structure_model_bytes(n_nodes=structure.n_nodes, n_members=structure.n_members)
    mujoco_bytes = model.nbuffer + data.nbuffer + model.narena
    return {
        "nodes": structure.n_nodes,
        "members": structure.n_members,
        "nv": model.nv,
        "nbody": model.nbody,
        "ntendon": model.ntendon,
        "nflexedge": model.nflexedge,
        "strut_elements": strut_elements,
        "nM": model.nM,
        "seconds": seconds,
        "total_s": sum(seconds.values()),
        "index_s": index_s,
        "compile_without_tendons_s": bare_compile_s,
        "member_compile_us_per_member": (seconds["compile"] - bare_compile_s) / structure.n_members * 1e6,
        "tendon_compile_ns_per_tendon_dof": (
            (seconds["compile"] - bare_compile_s) / (model.ntendon * model.nv) * 1e9 if model.ntendon else None
        ),
        "start_rss_mb": start_rss_mb,
        "peak_rss_mb": peak_rss_mb,
        "path_rss_mb": peak_rss_mb - start_rss_mb,
        "estimate_mb": estimate / 2**20,
        "path_rss_over_estimate": (peak_rss_mb - start_rss_mb) * 2**20 / estimate,
        "mujoco_mb": mujoco_bytes / 2**20,
        "mujoco_over_estimate": mujoco_bytes / estimate,
        "arena_mb": model.narena / 2**20,
    }


def _child(path: Path, strut_elements: str) -> int:
    print(json.dumps(run_path(path, strut_elements)), flush=True)
    return 0


def _run_child(path: Path, strut_elements: str) -> dict:
    done = subprocess.run(
        [sys.executable, __file__, "--child", str(path), "--strut-elements", strut_elements],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"error: {path.name}: the benchmark process failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def per_node_ratios(sizes: list[dict]) -> dict[str, list[float]]:
    """Per stage (the total and the compile without tendons too), each size's time per node over
    the smallest size's."""
    seconds = {stage: [s["seconds"][stage] for s in sizes] for stage in STAGES}
    seconds["total"] = [s["total_s"] for s in sizes]
    seconds["compile_without_tendons"] = [s["compile_without_tendons_s"] for s in sizes]
    nodes = [s["nodes"] for s in sizes]
    return {stage: [t / n / (times[0] / nodes[0]) for t, n in zip(times, nodes)] for stage, times in seconds.items()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--units", type=int, nargs="+", default=list(DEFAULT_UNITS), help="plate sizes (cubes a side)")
    p.add_argument(
        "--strut-elements", choices=STRUT_ELEMENTS, default="auto", help="build_structure_spec's strut_elements"
    )
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        return _child(Path(args.child), args.strut_elements)
    if min(args.units) < 1:
        p.error(f"--units: every size must be >= 1, got {args.units}")
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_structure_scale_") as folder:
        paths = [write_plate(units, Path(folder)) for units in sorted(args.units)]
        sizes = [
            {"units": units, **_run_child(path, args.strut_elements)} for units, path in zip(sorted(args.units), paths)
        ]
    largest = sizes[-1]
    print(
        json.dumps(
            {
                "machine": {
                    "cpu_count": os.cpu_count(),
                    "platform": platform.platform(),
                    "python": platform.python_version(),
                    "mujoco": mujoco.__version__,
                },
                "load_average": {"before": load_before, "after": os.getloadavg()},
                "sizes": sizes,
                "per_node_ratio": {"nodes": [s["nodes"] for s in sizes], **per_node_ratios(sizes)},
                "largest": {
                    "nodes": largest["nodes"],
                    "total_s": largest["total_s"],
                    "share": {stage: largest["seconds"][stage] / largest["total_s"] for stage in STAGES},
                },
            },
            indent=1,
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
