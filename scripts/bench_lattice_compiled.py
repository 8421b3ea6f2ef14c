r"""The 800-node lattice's RK4 step in MuJoCo against a compiled spring–mass RK4 of the same lattice.

Case A (19 × 19 cubes, 800 nodes, 3 402 struts, EI = 1e3 N m², d = 100 m, M = 100 kg,
cantilever-calibrated, ζ_s = 0.1) with the distributed bang-bang-off torque (τ_max = 0.1 N m about
x1 over the top-layer y1-struts, Robb et al. 2022a, Sec. 2, Table 1), RK4 at δt = 0.1 s. CPU time
per step (``time.process_time``), the rows timed one after the other in each of ``--rounds``
rounds and the best round kept (a shared machine slows CPU time in bursts):

1. compiled reference: :mod:`magsail_mj.reference.compiled_rk4`, the strut law and the strut
   torque at every RK stage in C (``magsail_mj/compiled/lattice_rk4.c``);
2. NumPy reference: :mod:`magsail_mj.reference.numpy_rk4`, the same equations vectorised;
3. the runner all-in: ``Simulation.run`` of the scenario (loads, the delivered-torque meter,
   probes, recorder every 3 s), with the config's load timing (``midpoint``) and with the loads at
   the step's start;
4. a minimal loop of ``mj_step`` with the scenario's loads added to ``xfrc_applied`` at the step's
   start (node positions from ``qpos``), on the tendon model and on the plugin model;
5. bare ``mj_step`` (no loads) of the tendon model (one spatial tendon per strut), of the plugin
   model (:func:`magsail_mj.lattice.compiled_springs.plugin_truss_model`: no tendons, the strut
   forces from the ``magsail.lattice_springs`` passive plugin) and of the same bodies with no
   strut forces at all (MuJoCo's floor); RK4, and Euler for comparison.

Each row's ratio is to the compiled reference of the same run. Then the stage profile, each part
best of ``--rounds`` rounds as well:

(a) MuJoCo's own profiler (``mjData.timer`` with ``mjcb_time`` set to the thread's CPU clock of
    the plugin library) over chunks of ``--profile-steps`` RK4 steps of each model, the cheapest
    chunk: per step, the ``mj_forward`` passes (4 per RK4 step) and their position (kinematics,
    com, tendons: ``pos_kinematics``; ``pos_inertia``; ``pos_make``) and velocity (com velocity,
    passive forces, bias forces) stages; "RK4 bookkeeping" is the step less its forward passes;
(b) the pipeline's functions called one by one (``mj_kinematics``, ``mj_comPos``, ``mj_tendon``,
    ``mj_makeM``, ``mj_factorM``, ``mj_comVel``, ``mj_passive``, ``mj_rne``,
    ``mj_fwdAcceleration``), CPU µs per call, the three models interleaved in each round;
(c) the runner's step (midpoint loads) split by wrappers: each load, the mid-step prediction,
    ``mj_step``, the state read-out, probes; "loop" is the rest (the run of least total time).

Agreement, printed beside: the compiled reference against the NumPy one (largest node distance
after the timed steps), and the plugin model against the tendon model (largest node distance and
velocity difference after ``--steps`` steps of the minimal loop with the loads).

    nice -n 10 python scripts/bench_lattice_compiled.py               # 300 steps per row, 5 rounds
    nice -n 10 python scripts/bench_lattice_compiled.py --out lattice_compiled.md
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from collections import defaultdict
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import mujoco
import numpy as np

import magsail_mj
from magsail_mj.concepts.truss_magnetorquer.metrics import PROFILE_AXES
from magsail_mj.config import load_config
from magsail_mj.control.profiles import torque_profile
from magsail_mj.io import print_report
from magsail_mj.lattice.compiled_springs import plugin_truss_model, profiler_clock
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec
from magsail_mj.loads.base import StepState
from magsail_mj.reference.compiled_rk4 import CompiledLattice, StrutCouples
from magsail_mj.reference.numpy_rk4 import from_truss_scenario, rk4_run
from magsail_mj.sim import Simulation

CASE_A = (
    Path(__file__).resolve().parents[1]
    / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_distributed_bangbang.toml"
)
DT_S = 0.1
TARGET_RATIO = 3.0
"""The all-in step should cost at most this many compiled-reference steps."""
EULER_DT_S = 0.25
"""Euler's step in the per-simulated-second column (the largest step of docs/performance.md's
Euler rows that agrees with RK4 in attitude and SD on this lattice)."""
RECORD_EVERY_S = 3.0
PIPELINE = (
    ("mj_kinematics", lambda m, d: mujoco.mj_kinematics(m, d)),
    ("mj_comPos", lambda m, d: mujoco.mj_comPos(m, d)),
    ("mj_tendon", lambda m, d: mujoco.mj_tendon(m, d)),
    ("mj_makeM", lambda m, d: mujoco.mj_makeM(m, d)),
    ("mj_factorM", lambda m, d: mujoco.mj_factorM(m, d)),
    ("mj_comVel", lambda m, d: mujoco.mj_comVel(m, d)),
    ("mj_passive", lambda m, d: mujoco.mj_passive(m, d)),
    ("mj_rne (bias forces)", lambda m, d: mujoco.mj_rne(m, d, 0, d.qfrc_bias)),
    ("mj_fwdAcceleration", lambda m, d: mujoco.mj_fwdAcceleration(m, d)),
    ("mj_forward (all of a stage)", lambda m, d: mujoco.mj_forward(m, d)),
)
"""The pipeline functions of one RK4 stage timed one by one (section (b))."""
TIMERS = ("forward", "position", "pos_kinematics", "pos_inertia", "pos_make", "velocity", "actuation", "constraint")
"""MuJoCo profiler entries reported per step (section (a))."""


@dataclass
class Row:
    name: str
    dt_s: float
    cpu_s: float = np.inf
    """Best CPU seconds per step over the rounds."""

    def take(self, cpu_s: float) -> None:
        self.cpu_s = min(self.cpu_s, cpu_s)


@dataclass
class Models:
    """The scenario and the three MuJoCo models of its lattice."""

    sim: Simulation
    tendon: mujoco.MjModel
    plugin: mujoco.MjModel
    none: mujoco.MjModel


def config(*, load_timing: str | None = None, duration_s: float = 30.0, integrator: str = "RK4", dt: float = DT_S):
    extra = [f"sim.load_timing='{load_timing}'"] if load_timing else []
    return load_config(
        CASE_A,
        [
            f"sim.integrator='{integrator}'",
            f"sim.timestep_s={dt}",
            f"sim.duration_s={duration_s}",
            f"sim.record_every={int(round(RECORD_EVERY_S / dt))}",
            "sim.progress=false",
            *extra,
        ],
    )


def profile_command(profile) -> Callable[[np.ndarray], np.ndarray]:
    """``τ(t)`` (T, 3) [N m] of the ``[profile]`` table, vectorised (the scenario's command)."""
    axis = PROFILE_AXES[profile.axis]

    def command(t: np.ndarray) -> np.ndarray:
        out = np.zeros((t.size, 3))
        p = profile
        out[:, axis] = torque_profile(p.kind, t, tau_max=p.tau_max_Nm, t_end=p.t_end_s, t_v=p.t_v_s)
        return out

    return command


def build_models(integrator: str = "RK4", dt: float = DT_S) -> Models:
    """The scenario (tendon model), the plugin model and the model without strut forces."""
    sim = magsail_mj.load(config(integrator=integrator, dt=dt))
    tm = sim.scenario.tm
    options = TrussModelOptions(timestep_s=dt, integrator=integrator)
    plugin = plugin_truss_model(tm.lattice, masses=tm.masses, stiffness=tm.k, damping=tm.gamma, options=options)
    lat = tm.lattice
    bare = replace(lat, struts=lat.struts[:0], kind=lat.kind[:0], rest_length=lat.rest_length[:0], _cache={})
    none = build_truss_spec(bare, masses=tm.masses, stiffness=np.zeros(0), damping=0.0, options=options).compile()
    return Models(sim=sim, tendon=sim.model, plugin=plugin, none=none)


def start_data(model: mujoco.MjModel, scenario, *, forward: bool = True) -> mujoco.MjData:
    """The scenario's initial state in a fresh ``MjData`` of ``model`` (same qpos layout: the
    same free nodes, three slide joints each); ``forward``: with ``mj_forward`` run on it."""
    ref = mujoco.MjData(scenario.model)
    scenario.init_state(ref)
    if model.nq != ref.qpos.size or model.nq != 3 * (model.nbody - 1):
        raise ValueError(f"model: expected {ref.qpos.size} = 3 × free nodes joint coordinates, got {model.nq}")
    d = mujoco.MjData(model)
    d.qpos[:], d.qvel[:] = ref.qpos, ref.qvel
    if forward:
        mujoco.mj_forward(model, d)
    return d


def cpu_per_call(f: Callable[[], object], n: int) -> float:
    """CPU seconds per call of ``f`` over ``n`` calls."""
    c0 = time.process_time()
    for _ in range(n):
        f()
    return (time.process_time() - c0) / n


def loaded_loop(model: mujoco.MjModel, scenario, n_steps: int) -> tuple[float, np.ndarray, np.ndarray]:
    """``n_steps`` of ``mj_step`` with the scenario's loads at each step's start (module docs, 4).
    Returns (CPU s per step, final qpos, final qvel)."""
    d = start_data(model, scenario)
    loads = scenario.loads()
    nb = model.nbody
    pos0 = model.body_pos.copy()
    pos, vel = pos0.copy(), np.zeros((nb, 3))
    xquat, omega = np.tile([1.0, 0.0, 0.0, 0.0], (nb, 1)), np.zeros((nb, 3))
    dt = model.opt.timestep
    c0 = time.process_time()
    for step in range(n_steps):
        pos[1:] = pos0[1:] + d.qpos.reshape(-1, 3)
        vel[1:] = d.qvel.reshape(-1, 3)
        state = StepState(t=step * dt, pos=pos, vel=vel, xquat=xquat, omega=omega)
        d.xfrc_applied[:] = 0.0
        for load in loads:
            load.add(state, d.xfrc_applied)
        mujoco.mj_step(model, d)
    return (time.process_time() - c0) / n_steps, d.qpos.copy(), d.qvel.copy()


def runner_cpu(load_timing: str, n_steps: int) -> float:
    """CPU s per step of ``Simulation.run`` (module docs, 3); the build is not timed."""
    sim = magsail_mj.load(config(load_timing=load_timing, duration_s=n_steps * DT_S))
    c0 = time.process_time()
    res = sim.run(progress=False)
    cpu = time.process_time() - c0
    if res.status != "completed":
        raise RuntimeError(f"runner ({load_timing}): {res.status} {res.message}")
    return cpu / max(res.steps, 1)


def bare_cpu(model: mujoco.MjModel, scenario, n_steps: int) -> float:
    """CPU s per bare ``mj_step`` of ``model`` from the scenario's initial state."""
    d = start_data(model, scenario)
    return cpu_per_call(lambda: mujoco.mj_step(model, d), n_steps)


def timed_rows(models: Models, euler: Models, args, log) -> tuple[list[Row], dict]:
    """The rows (module docs, 1–5), best of ``args.rounds`` rounds, and the agreement figures."""
    sc = models.sim.scenario
    system, external, x0, v0 = from_truss_scenario(sc)
    compiled = CompiledLattice(system, couples=StrutCouples.from_load(sc.torque_load, profile_command(sc.cfg.profile)))
    n = args.steps
    tau = compiled.commands(t0=0.0, dt=DT_S, n_steps=n)
    names = [
        ("compiled reference (C RK4, springs + strut torque at every stage)", DT_S),
        ("NumPy reference (vectorised RK4, same equations)", DT_S),
        ("runner all-in, RK4, loads at the mid-step (the config's timing)", DT_S),
        ("runner all-in, RK4, loads at the step's start", DT_S),
        ("mj_step + the loads (minimal loop), tendon model", DT_S),
        ("mj_step + the loads (minimal loop), plugin model", DT_S),
        ("bare mj_step RK4, tendon model (3 402 tendons)", DT_S),
        ("bare mj_step RK4, plugin model (no tendons)", DT_S),
        ("bare mj_step RK4, no strut forces (MuJoCo's floor)", DT_S),
        ("bare mj_step Euler, tendon model", EULER_DT_S),
        ("bare mj_step Euler, plugin model", EULER_DT_S),
    ]
    rows = [Row(name, dt) for name, dt in names]
    info: dict = {}
    for r in range(args.rounds):
        c0 = time.process_time()
        xc, _, _ = compiled.run(x0, v0, dt=DT_S, n_steps=n, tau=tau)
        rows[0].take((time.process_time() - c0) / n)
        c0 = time.process_time()
        xn, _, _ = rk4_run(system, x0, v0, dt=DT_S, duration=n * DT_S, external=external)
        rows[1].take((time.process_time() - c0) / n)
        info["ref_dist_m"] = float(np.max(np.linalg.norm(xc - xn, axis=1)))
        rows[2].take(runner_cpu("midpoint", n))
        rows[3].take(runner_cpu("start", n))
        cpu_t, qt, vt = loaded_loop(models.tendon, sc, n)
        cpu_p, qp, vp = loaded_loop(models.plugin, sc, n)
        rows[4].take(cpu_t)
        rows[5].take(cpu_p)
        info["plugin_dist_m"] = float(np.max(np.linalg.norm((qp - qt).reshape(-1, 3), axis=1)))
        info["plugin_dvel_m_s"] = float(np.max(np.abs(vp - vt)))
        info["moved_m"] = float(np.max(np.abs(qt - start_data(models.tendon, sc).qpos)))
        for row, model in zip(rows[6:9], (models.tendon, models.plugin, models.none)):
            row.take(bare_cpu(model, sc, n))
        for row, model in zip(rows[9:], (euler.tendon, euler.plugin)):
            row.take(bare_cpu(model, euler.sim.scenario, n))
        log(f"round {r + 1}/{args.rounds}, best so far: " + ", ".join(f"{row.cpu_s * 1e6:.0f}" for row in rows) + " µs")
    return rows, info


def mujoco_timers(model: mujoco.MjModel, scenario, n_steps: int, chunks: int) -> dict[str, float]:
    """MuJoCo's profiler over ``chunks`` chunks of ``n_steps`` steps: µs per step of each
    :data:`TIMERS` entry, the step and the forward passes per step, of the chunk whose steps cost
    least (the timers accumulate; each chunk is the difference of two snapshots)."""
    names = list(mujoco.mjTIMERSTRING)
    keys = ("step", *TIMERS)
    d = start_data(model, scenario)

    def snapshot() -> dict[str, tuple[float, int]]:
        return {k: (d.timer[names.index(k)].duration, d.timer[names.index(k)].number) for k in keys}

    best: dict[str, float] = {"step": np.inf}
    for _ in range(chunks):
        before = snapshot()
        for _ in range(n_steps):
            mujoco.mj_step(model, d)
        after = snapshot()
        out = {k: (after[k][0] - before[k][0]) / n_steps for k in keys}
        out["forward passes"] = (after["forward"][1] - before["forward"][1]) / n_steps
        if out["step"] < best["step"]:
            best = out
    return best


def pipeline_costs(models: dict[str, mujoco.MjModel], scenario, rounds: int, n: int = 50) -> dict[str, dict]:
    """CPU µs per call of each :data:`PIPELINE` function of each model (module docs, (b)), the
    models interleaved in each of ``rounds`` rounds, best of the rounds."""
    datas = {}
    for name, model in models.items():
        d = start_data(model, scenario)
        d.qvel[:] += 1e-3 * np.random.default_rng(0).standard_normal(model.nv)  # a moving, deforming state
        for _ in range(10):
            mujoco.mj_step(model, d)
        datas[name] = d
    best = {name: {f: np.inf for f, _ in PIPELINE} for name in models}
    for _ in range(rounds):
        for name, model in models.items():
            d = datas[name]
            for f, call in PIPELINE:
                best[name][f] = min(best[name][f], cpu_per_call(lambda: call(model, d), n))
    return {name: {f: v * 1e6 for f, v in b.items()} for name, b in best.items()}


def runner_profile(n_steps: int) -> tuple[dict[str, float], float]:
    """One run of the runner's step (midpoint loads) split by wrappers (module docs, (c)): µs per
    step by part and the total, CPU time of the thread."""
    sim = magsail_mj.load(config(load_timing="midpoint", duration_s=n_steps * DT_S))
    spent: dict[str, float] = defaultdict(float)

    def timed(fn, key):
        def wrapper(*a, **kw):
            t0 = time.thread_time()
            try:
                return fn(*a, **kw)
            finally:
                spent[key] += time.thread_time() - t0

        return wrapper

    for load in sim.loads:
        load.add = timed(load.add, f"load: {load.name}")
    sim._mid_state = timed(sim._mid_state, "mid-step prediction (state at t + δt/2)")
    sim.kin.update = timed(sim.kin.update, "state read-out")
    sim.probes = {k: timed(p, "probes (record steps)") for k, p in sim.probes.items()}
    mj_step = mujoco.mj_step
    mujoco.mj_step = timed(mj_step, "MuJoCo mj_step")
    try:
        t0 = time.thread_time()
        res = sim.run(progress=False)
        total = time.thread_time() - t0
    finally:
        mujoco.mj_step = mj_step
    n = max(res.steps, 1)
    spent["loop (runner)"] = total - sum(spent.values())
    return {k: v / n * 1e6 for k, v in spent.items()}, total / n * 1e6


def rows_table(rows: list[Row]) -> list[str]:
    ref = rows[0].cpu_s
    lines = [
        "| row | δt [s] | CPU µs per step | / compiled reference | CPU ms per simulated s |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.name} | {r.dt_s:g} | {r.cpu_s * 1e6:.0f} | {r.cpu_s / ref:.2f} | {r.cpu_s / r.dt_s * 1e3:.2f} |"
        )
    return lines


def timers_table(timers: dict[str, dict[str, float]]) -> list[str]:
    names = list(timers)
    lines = ["| MuJoCo timer, µs per RK4 step | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for key in ("step", *TIMERS):
        lines.append(f"| {key} | " + " | ".join(f"{timers[m][key]:.0f}" for m in names) + " |")
    lines.append(
        "| RK4 bookkeeping (step − forward) | "
        + " | ".join(f"{timers[m]['step'] - timers[m]['forward']:.0f}" for m in names)
        + " |"
    )
    lines.append("| forward passes per step | " + " | ".join(f"{timers[m]['forward passes']:g}" for m in names) + " |")
    return lines


def pipeline_table(costs: dict[str, dict[str, float]], compiled_us: float) -> list[str]:
    names = list(costs)
    lines = ["| function, CPU µs per call (× 4 per RK4 step) | " + " | ".join(names) + " |"]
    lines.append("|---" * (len(names) + 1) + "|")
    for key, _ in PIPELINE:
        lines.append(f"| {key} | " + " | ".join(f"{costs[m][key]:.1f}" for m in names) + " |")
    lines.append(
        "| 4 × mj_forward / compiled reference step | "
        + " | ".join(f"{4 * costs[m]['mj_forward (all of a stage)'] / compiled_us:.2f}" for m in names)
        + " |"
    )
    return lines


def conclusion(rows: list[Row], info: dict) -> list[str]:
    ref = rows[0].cpu_s
    allin = min(rows[2].cpu_s, rows[3].cpu_s)
    ratio = allin / ref
    floor = rows[8].cpu_s / ref
    verdict = "met" if ratio <= TARGET_RATIO else "not met"
    lines = [
        f"- Target (all-in RK4 step within {TARGET_RATIO:g}× of the compiled reference): **{verdict}**: the "
        f"cheaper runner row costs {allin * 1e6:.0f} µs, {ratio:.1f}× the compiled reference's "
        f"{ref * 1e6:.0f} µs.",
        f"- Plugin forces instead of tendons: bare mj_step {rows[6].cpu_s * 1e6:.0f} → {rows[7].cpu_s * 1e6:.0f} µs "
        f"({rows[6].cpu_s / rows[7].cpu_s:.2f}× cheaper), {rows[7].cpu_s / ref:.1f}× the compiled reference; "
        f"with the loads {rows[4].cpu_s * 1e6:.0f} → {rows[5].cpu_s * 1e6:.0f} µs.",
        f"- MuJoCo's floor (same bodies and joints, no strut forces at all): {rows[8].cpu_s * 1e6:.0f} µs per RK4 "
        f"step = {floor:.1f}× the compiled reference: "
        + (
            f"no strut-force implementation inside MuJoCo's RK4 can reach {TARGET_RATIO:g}×."
            if floor > TARGET_RATIO
            else f"below {TARGET_RATIO:g}×, so cheaper forces and loads could reach the target."
        ),
        f"- Agreement: compiled vs NumPy reference, largest node distance after {info['steps']} steps "
        f"{info['ref_dist_m']:.1e} m; plugin vs tendon model (minimal loop with the loads, {info['steps']} steps, "
        f"nodes moved up to {info['moved_m']:.1e} m) largest node distance {info['plugin_dist_m']:.1e} m, "
        f"velocity difference {info['plugin_dvel_m_s']:.1e} m/s.",
    ]
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300, help="RK4 steps per timed row (default 300 = 30 s)")
    ap.add_argument("--rounds", type=int, default=5, help="rounds of all rows; the best round of each row is kept")
    ap.add_argument("--profile-steps", type=int, default=100, help="steps of the profiles (a) and (c)")
    ap.add_argument("--out", type=Path, default=None, help="also write the report here")
    args = ap.parse_args(argv)
    if args.steps < 1 or args.rounds < 1 or args.profile_steps < 1:
        raise SystemExit("--steps, --rounds, --profile-steps: must be >= 1")
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    models = build_models()
    euler = build_models("Euler", EULER_DT_S)
    sc = models.sim.scenario
    m = models.tendon
    log(f"models: {m.nbody} bodies, {m.nv} dofs, {m.ntendon} tendons; plugin model {models.plugin.ntendon} tendons")
    rows, info = timed_rows(models, euler, args, log)
    info["steps"] = args.steps
    three = {"tendons": models.tendon, "plugin": models.plugin, "no strut forces": models.none}
    clock = profiler_clock()
    mujoco.set_mjcb_time(clock)
    try:
        timers = {name: mujoco_timers(model, sc, args.profile_steps, args.rounds) for name, model in three.items()}
    finally:
        mujoco.set_mjcb_time(None)
    costs = pipeline_costs(three, sc, args.rounds)
    parts, total_us = min((runner_profile(args.profile_steps) for _ in range(args.rounds)), key=lambda pt: pt[1])
    log("profiles done")
    lines = [
        f"Case A lattice: {m.nbody - 1} nodes (bodies), {m.nv} dofs (3 slide joints per node), {m.ntendon} spatial "
        f"tendons ({m.nwrap} wrap sites); {sc.torque_load.struts.size} actuated struts; plugin model: "
        f"{models.plugin.ntendon} tendons, {models.plugin.nplugin} plugin instance. {args.steps} steps per row, "
        f"best of {args.rounds} rounds, CPU time.",
        "",
        *rows_table(rows),
        "",
        *conclusion(rows, info),
        "",
        f"(a) MuJoCo's profiler (thread CPU time), {args.profile_steps} RK4 steps:",
        "",
        *timers_table(timers),
        "",
        "(b) Pipeline functions of one stage:",
        "",
        *pipeline_table(costs, rows[0].cpu_s * 1e6),
        "",
        f"(c) The runner's RK4 step with mid-step loads, {total_us:.0f} µs ({args.profile_steps} steps, wrappers):",
        "",
        "| part | µs per step | share |",
        "|---|---|---|",
        *(f"| {k} | {v:.0f} | {v / total_us:.0%} |" for k, v in sorted(parts.items(), key=lambda kv: -kv[1])),
        "",
        f"Python {platform.python_version()}, NumPy {np.__version__}, MuJoCo {mujoco.__version__}, "
        f"{platform.processor() or platform.machine()}.",
    ]
    print_report("\n".join(lines), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
