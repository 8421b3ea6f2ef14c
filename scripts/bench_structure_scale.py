"""A structure file to its first MuJoCo step at about 2 000, 6 000 and 20 000 nodes: each stage's
time, its growth per node with a fitted exponent, MuJoCo's superlinear compile phases timed on
their own, and the peak memory against the estimate.

For each size (square plate lattices of ``units`` cubes a side, two layers: ``2 (units + 1)²``
nodes, struts only; the default 31, 54, 99 give 2 048, 6 050 and 20 000 nodes) the plate is
written as a structure file with an ``.npz`` companion
(:func:`~magsail_mj.structure.fileformat.write_structure`, not timed), then a fresh process runs
and times each stage of the path once (wall clock, and the process's CPU time):

* ``read`` — :func:`~magsail_mj.structure.fileformat.read_structure` (TOML, the ``.npz`` arrays,
  and the checks it runs itself);
* ``check`` — :func:`~magsail_mj.structure.checks.check_structure` again, on its own;
* ``build`` — :func:`~magsail_mj.structure.mjcf.build_structure_spec` (Euler, with
  ``--strut-elements``: ``flex`` by default, every size's struts as 1-D flex edges, so that the
  sizes are the same kind of model; ``auto`` builds the same flexes for the 6 050- and 20 000-node
  plates, above ``FLEX_AUTO_TENDON_DOFS``, and tendons for the 2 048-node one);
* ``compile`` — ``spec.compile()``;
* ``data`` — ``mujoco.MjData(model)``;
* ``step`` — the first ``mujoco.mj_step``.

The parts: ``ours`` (read, check, build: this package's Python), ``compile`` (MuJoCo's) and
``first_step`` (data and step). For each stage and part, ``scaling`` gives the time per node
[µs], its ratio to the smallest size's (1 at every size for a cost linear in the node count) and
``exponent``, the least-squares slope of ``log t`` over ``log nodes`` (1: linear, 2: quadratic).

MuJoCo's compile holds two phases quadratic in the size of a model whose moving bodies hang from
the world (as a lattice's particles do), both MuJoCo 4.0.0's own code; after the compile the
benchmark calls each again, through ``ctypes`` on the same ``libmujoco``, on the compiled model's
arrays (they are deterministic functions of them) and times it alone (``mujoco_phases``):

* ``mj_makeBSparse`` — the body-dof sparsity ``B``: the world body's row lists all ``nv`` dofs,
  gathered from the bodies in reverse order and then sorted by ``mju_insertionSortInt``, about
  ``nv² / 2`` moves (``nv``: 3 per particle), whatever the tree: inherent to MuJoCo;
* ``mj_validateReferences`` — for every body, a check that its row of ``B`` is a subset of its
  parent's, scanning the parent's row from its start: ``O(nv)`` for each child of the world,
  ``O(nbody · nv)`` in all (located with ``perf annotate`` on the check's loop, which reads
  ``B_rownnz``, ``B_rowadr``, ``B_colind`` and ``body_parentid``). Hanging the particles from
  ``√n`` dof-less bodies would make it ``O(n^1.5)`` (0.40 s to 0.008 s at 20 000 particles,
  measured), but every particle would then no longer be a child of the world, which the
  simulator's particle state path (:mod:`magsail_mj.sim`) requires; the builder keeps them there.

``compile_rest`` is the compile without those two phases. ``fresh_mb`` is, per stage, the memory
it touched for the first time (minor page faults × page size: for the compile, MuJoCo's model and
its data and arena, zeroed), linear in the size; on a machine where a first touch is slow
(1.8 ms/MiB measured on the shared machine) it is paid in full only above glibc's ``mmap``
threshold (at most 32 MiB: not at 2 048 nodes, whose memory comes back from freed heap), which
raises a stage's per-node ratio by a step rather than a power.

Our build's own superlinear part is MuJoCo's spec API: an element added to an ``MjSpec`` rebuilds
its element lists (``ResetTreeLists``, ``MakeTreeLists``: the MjSpec's size), and an attach costs the
receiving spec's size (:class:`~magsail_mj.lattice.mjcf.WorldTrees`: chunks of 64 bodies, about
``√k`` groups). ``build_attach`` times every ``MjSpec.attach`` of the build (the method wrapped in
the benchmark process): ``into_spec`` the groups attached into the returned spec, ``into_groups``
the chunks into their groups; ``build_rest`` in the table is the build without them.

``compile_without_tendons_s`` (timed after the path, not in ``total_s``) is the compile of the same
plate without its members (nodes only), which splits ``compile`` into MuJoCo's part that grows
with the members and the rest: ``member_compile_us_per_member`` is the difference over the member
count (constant when that part is linear, as with flex edges), ``tendon_compile_ns_per_tendon_dof``
the same over ``ntendon · nv`` (constant when it is ``O(ntendon nv)``, as MuJoCo's per-tendon
``tendon_invweight0`` over dense ``nv``-vectors is; ``null`` without tendons).

The process reports its peak resident set (``ru_maxrss``: MuJoCo's C
allocations included, which ``tracemalloc`` does not see) and the resident set it had before the
read (the interpreter and the imports): their difference is the path's own memory, compared with
:func:`~magsail_mj.resources.structure_model_bytes` of the plate's node and member counts; so is
MuJoCo's own part, ``MjModel.nbuffer + MjData.nbuffer + narena``. ``largest`` holds the largest
size's ``total_s`` with the stage shares and ``within_limits``: file to first step within
:data:`LARGEST_TOTAL_S` and the path's memory within the estimate. ``load_average`` is
``os.getloadavg()`` before and after: the machine may be shared, and timings are wall-clock (CPU
time beside them); compare ratios measured in one call.

Measured (MuJoCo 4.0.0, the shared 2-core machine at load 6–7): 20 000 nodes from file to first
step in 12.1 s (build 5.8 s, compile 5.9 s), path memory 0.44 of the estimate; fitted exponents
total 1.40, ours 1.26 (CPU 1.12), compile 1.65 (CPU 1.47), first step 0.92; ``mj_makeBSparse``
2.26 and ``mj_validateReferences`` 2.14 (30 % and 18 % of the 20 000-node compile), the rest of the
compile 1.43; the build's attaches into the returned spec 2.2 (0.81 s), the rest of the build 1.23.
Unloaded, called on their own: ``mj_makeBSparse`` 0.0055, 0.054, 0.51 s and
``mj_validateReferences`` 0.0041, 0.038, 0.37 s at 2 048, 6 272 and 20 000 nodes (exponent 2.0
each); at load 1–2 the 20 000-node plate took 11.3 s from file to first step.

    .venv/bin/python scripts/bench_structure_scale.py                 # units 31, 54, 99
    .venv/bin/python scripts/bench_structure_scale.py --units 15 31 63
    .venv/bin/python scripts/bench_structure_scale.py --strut-elements auto     # as the config path builds
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import dataclasses
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
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
#: The parts of the path the scaling table sums stages into.
PARTS = {"ours": ("read", "check", "build"), "compile": ("compile",), "first_step": ("data", "step")}
#: MuJoCo's compile phases timed on their own (module docstring).
MUJOCO_PHASES = ("mj_makeBSparse", "mj_validateReferences")
DEFAULT_UNITS = (31, 54, 99)
SIDE_M, EA_N, MASS_KG, ZETA = 100.0, 1.0e6, 100.0, 0.01
TIMESTEP_S = 1e-3
#: The largest plate's file to first step must take at most this [s].
LARGEST_TOTAL_S = 30.0
_INT_P = ctypes.POINTER(ctypes.c_int)


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


def _libmujoco() -> ctypes.CDLL:
    """The ``libmujoco`` shared library the ``mujoco`` package loaded, with the two phases' signatures."""
    found = sorted(Path(mujoco.__file__).parent.glob("libmujoco.so*"))
    if not found:
        raise SystemExit(f"error: no libmujoco.so* next to {mujoco.__file__}")
    lib = ctypes.CDLL(str(found[0]))
    lib.mj_validateReferences.restype = ctypes.c_char_p
    lib.mj_validateReferences.argtypes = [ctypes.c_void_p]
    lib.mj_makeBSparse.restype = None
    lib.mj_makeBSparse.argtypes = [ctypes.c_int] * 3 + [_INT_P] * 7
    return lib


def time_mujoco_phases(model: mujoco.MjModel) -> dict[str, float]:
    """Seconds of ``mj_makeBSparse`` and ``mj_validateReferences`` called again on ``model``'s
    arrays (module docstring); the rebuilt ``B`` must equal the model's."""
    lib = _libmujoco()

    def ints(values) -> np.ndarray:
        return np.ascontiguousarray(values, dtype=np.int32)

    def pointer(array: np.ndarray):
        return array.ctypes.data_as(_INT_P)

    dofnum, parent, dofadr = ints(model.body_dofnum), ints(model.body_parentid), ints(model.body_dofadr)
    nB = int(model.B_rownnz.sum())
    rownnz, rowadr, count = (np.zeros(model.nbody, dtype=np.int32) for _ in range(3))
    colind = np.zeros(nB, dtype=np.int32)
    t0 = time.perf_counter()
    lib.mj_makeBSparse(
        model.nv, model.nbody, nB, *map(pointer, (dofnum, parent, dofadr, rownnz, rowadr, colind, count))
    )
    seconds = {"mj_makeBSparse": time.perf_counter() - t0}
    if not np.array_equal(colind, model.B_colind):
        raise SystemExit("error: mj_makeBSparse called again gave another B_colind than the compiled model's")
    t0 = time.perf_counter()
    invalid = lib.mj_validateReferences(ctypes.c_void_p(model._address))
    seconds["mj_validateReferences"] = time.perf_counter() - t0
    if invalid is not None:
        raise SystemExit(f"error: mj_validateReferences: {invalid.decode()}")
    return seconds


@contextlib.contextmanager
def _timed_attaches() -> Iterator[list[tuple[mujoco.MjSpec, float]]]:
    """Within the block, every ``MjSpec.attach`` is timed: the list holds ``(receiver, seconds)``
    per call (the receivers are kept, so that none is confused with a later one)."""
    calls: list[tuple[mujoco.MjSpec, float]] = []
    attach = mujoco.MjSpec.attach

    def timed(receiver: mujoco.MjSpec, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return attach(receiver, *args, **kwargs)
        finally:
            calls.append((receiver, time.perf_counter() - t0))

    mujoco.MjSpec.attach = timed
    try:
        yield calls
    finally:
        mujoco.MjSpec.attach = attach


def run_path(path: Path, strut_elements: str = "auto") -> dict:
    """Time each stage of the path for the structure file ``path`` (in this process), struts
    built as ``strut_elements``."""
    start_rss_mb = _rss_mb()
    seconds: dict[str, float] = {}
    cpu_seconds: dict[str, float] = {}
    faults: dict[str, int] = {}

    def timed(stage: str, call):
        minflt = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        c0, t0 = time.process_time(), time.perf_counter()
        out = call()
        seconds[stage] = time.perf_counter() - t0
        cpu_seconds[stage] = time.process_time() - c0
        faults[stage] = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - minflt
        return out

    structure = timed("read", lambda: read_structure(path).structure)
    timed("check", lambda: check_structure(structure))
    with _timed_attaches() as attaches:
        spec = timed(
            "build",
            lambda: build_structure_spec(
                structure, timestep_s=TIMESTEP_S, integrator="Euler", strut_elements=strut_elements
            ),
        )
    build_attach = {
        "into_spec_s": sum(dt for receiver, dt in attaches if receiver is spec),
        "into_spec_count": sum(1 for receiver, _ in attaches if receiver is spec),
        "into_groups_s": sum(dt for receiver, dt in attaches if receiver is not spec),
        "into_groups_count": sum(1 for receiver, _ in attaches if receiver is not spec),
    }
    model = timed("compile", spec.compile)
    data = timed("data", lambda: mujoco.MjData(model))
    timed("step", lambda: mujoco.mj_step(model, data))
    t0 = time.perf_counter()
    StructureModelIndex.from_model(model, structure)
    index_s = time.perf_counter() - t0
    peak_rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    phases = time_mujoco_phases(model)
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
        "cpu_seconds": cpu_seconds,
        "total_s": sum(seconds.values()),
        "index_s": index_s,
        "mujoco_phases": {**phases, "compile_rest": seconds["compile"] - sum(phases.values())},
        "build_attach": build_attach,
        "fresh_mb": {stage: faults[stage] * resource.getpagesize() / 2**20 for stage in STAGES},
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


def fitted_exponent(nodes: list[int], seconds: list[float]) -> float | None:
    """The least-squares slope ``p`` of ``log t = p log n + c`` (``t ∝ n^p``); ``None`` with fewer
    than two distinct sizes or a time that is not positive."""
    n, t = np.asarray(nodes, dtype=float), np.asarray(seconds, dtype=float)
    if np.unique(n).size < 2 or not np.all(t > 0):
        return None
    return float(np.polyfit(np.log(n), np.log(t), 1)[0])


def stage_series(sizes: list[dict]) -> dict[str, list[float]]:
    """Wall seconds per size of each stage, part, MuJoCo phase and the total (and the compile
    without members), keyed by name."""
    series = {stage: [s["seconds"][stage] for s in sizes] for stage in STAGES}
    series.update({part: [sum(s["seconds"][x] for x in stages) for s in sizes] for part, stages in PARTS.items()})
    series["total"] = [s["total_s"] for s in sizes]
    for phase in (*MUJOCO_PHASES, "compile_rest"):
        series[phase] = [s["mujoco_phases"][phase] for s in sizes]
    series["build_attach_into_spec"] = [s["build_attach"]["into_spec_s"] for s in sizes]
    series["build_attach_into_groups"] = [s["build_attach"]["into_groups_s"] for s in sizes]
    series["build_rest"] = [
        s["seconds"]["build"] - s["build_attach"]["into_spec_s"] - s["build_attach"]["into_groups_s"] for s in sizes
    ]
    series["compile_without_tendons"] = [s["compile_without_tendons_s"] for s in sizes]
    return series


def per_node_ratios(sizes: list[dict]) -> dict[str, list[float]]:
    """Per stage, part and phase, each size's time per node over the smallest size's (``None``
    where the smallest size took none: no attach below ``SPEC_DIRECT_BODIES`` bodies)."""
    nodes = [s["nodes"] for s in sizes]
    return {
        name: [t / n / (times[0] / nodes[0]) if times[0] > 0 else None for t, n in zip(times, nodes)]
        for name, times in stage_series(sizes).items()
    }


def scaling(sizes: list[dict]) -> dict[str, dict]:
    """Per stage, part and phase: time per node [µs] at each size, its ratio to the smallest
    size's, and the fitted exponent (wall clock; for stages and parts also from CPU time)."""
    nodes = [s["nodes"] for s in sizes]
    ratios = per_node_ratios(sizes)
    out = {}
    for name, times in stage_series(sizes).items():
        row = {
            "us_per_node": [t / n * 1e6 for t, n in zip(times, nodes)],
            "ratio": ratios[name],
            "exponent": fitted_exponent(nodes, times),
        }
        stages = PARTS.get(name, (name,) if name in STAGES else None)
        if stages is not None:
            cpu = [sum(s["cpu_seconds"][x] for x in stages) for s in sizes]
            row["cpu_exponent"] = fitted_exponent(nodes, cpu)
        out[name] = row
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--units", type=int, nargs="+", default=list(DEFAULT_UNITS), help="plate sizes (cubes a side)")
    p.add_argument(
        "--strut-elements", choices=STRUT_ELEMENTS, default="flex", help="build_structure_spec's strut_elements"
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
    table = scaling(sizes)
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
                "scaling": {"nodes": [s["nodes"] for s in sizes], **table},
                "mujoco_superlinear": {
                    phase: {
                        "exponent": table[phase]["exponent"],
                        "share_of_compile": [s["mujoco_phases"][phase] / s["seconds"]["compile"] for s in sizes],
                    }
                    for phase in MUJOCO_PHASES
                },
                "largest": {
                    "nodes": largest["nodes"],
                    "total_s": largest["total_s"],
                    "share": {stage: largest["seconds"][stage] / largest["total_s"] for stage in STAGES},
                    "within_limits": bool(
                        largest["total_s"] <= LARGEST_TOTAL_S and largest["path_rss_over_estimate"] <= 1.0
                    ),
                },
            },
            indent=1,
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
