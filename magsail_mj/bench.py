r"""``magsail bench``: the cost of a config's step loop, against MuJoCo's bare step of the same model.

:func:`bench` builds the config's simulation through :func:`magsail_mj.load` (the
:class:`~magsail_mj.sim.Simulation` of the Python-stepped scenarios, the MSAC runner with the same
interface) and measures, on one process with one BLAS thread:

1. **all-in** (``us_per_step``): wall time of the step loop of ``run()`` (the runner's
   ``wall_time_s``: every per-step part, records streamed to a temporary Zarr store as ``magsail
   run`` does) divided by the steps it took, for ``repeat`` fresh builds; the median is reported,
   every pass in ``us_per_step_runs``. The one-off cost of the call around the loop (creating the
   store, reading the records back) is ``run_setup_s`` [s] (median);
2. **bare step** (``mj_step_us``): a copy of the model and a new ``MjData`` set to the run's
   initial physics state (``time``, ``qpos``, ``qvel``, ``act``; no ``ctrl``, no applied forces),
   stepped the same number of times by ``mujoco.mj_step(m, d)`` from Python, same integrator and
   timestep, no loads, controller or callbacks; median of ``repeat`` passes, each pass right after
   its all-in pass. ``mj_step_native_us`` is the same steps in one ``mj_step(m, d, nstep)`` call
   (MuJoCo's floor, without the per-call binding cost);
3. **ratio** ``ratio_to_mj_step = us_per_step / mj_step_us``;
4. **parts** (``parts_us``, µs per step): a further, instrumented pass in which every load's
   ``add`` (``load: <name>``), the controller (``update`` and the held command's ``apply_ctrl``),
   the environment sample, the state read-out (``kinematics``), the probes, the recorder, the
   strain check and ``mujoco.mj_step`` are timed by wrappers (``time.perf_counter`` around each
   call, ≈ 0.1–0.3 µs of overhead per call, counted in the part); ``loop`` is the rest of the
   instrumented pass (the runner's own bookkeeping, divergence checks, the wrappers' calls, and
   for the MSAC runner the native rollout). The parts sum to ``instrumented_us_per_step``; the
   all-in figure comes from the uninstrumented passes, so the wrappers do not perturb it;
5. ``steps_per_s = 10⁶ / us_per_step``, ``realtime_factor = δt / (us_per_step · 10⁻⁶ s)``
   (simulated seconds per wall second) and ``peak_rss_mb`` (the process's peak resident set,
   ``resource.getrusage``, MiB);
6. **compiled loads** (scenarios that have them, :mod:`magsail_mj.compiled`): ``loads`` is the
   config's ``sim.loads``; for a config on the Python path, the same all-in passes with
   ``sim.loads = "compiled"`` give ``us_per_step_compiled`` (median, every pass in
   ``us_per_step_compiled_runs``) and ``ratio_to_mj_step_compiled`` against the same bare step
   (or ``compiled_unavailable``: why not, e.g. no C compiler). The bare step is always that of the
   model without the plugin (``Simulation.compiled.bare_model``), so a compiled run's ratio counts
   the plugin's work as the loads' cost.

Timings are wall-clock and depend on the machine and its load: compare ratios measured in the
same call, never absolute times across machines.

**Batched worlds** (``worlds=N``, :func:`bench_worlds`): the config's batch of N identical worlds
(:func:`magsail_mj.batch.load_batch`, ``nthread`` threads) is run for the same steps, each world's
records streamed to its own temporary Zarr store, and the report gives ``worlds``, ``nthread``,
``us_per_world_step`` (the batch's step-loop wall time over the world-steps it took),
``cpu_us_per_world_step`` (the process's CPU time over the same, every thread counted, the
threads writing the records' stores too), ``mj_step_us`` (the bare single-thread ``mj_step`` of
world 0's model, as above) and ``mj_step_cpu_us`` (its thread's CPU time),
``ratio_to_mj_step = us_per_world_step / mj_step_us`` and ``cpu_ratio_to_mj_step =
cpu_us_per_world_step / mj_step_cpu_us`` (CPU to CPU: robust to other processes taking the cores
from the wall time), medians of
``repeat`` passes, and ``build_s`` (the batch's build, median). For a config on the Python path
whose scenario has compiled loads, the same passes with ``sim.loads = "compiled"`` (the batch's
worlds on models with the plugin, stepped natively between the controller's samples and the
records) add ``us_per_world_step_compiled``, ``cpu_us_per_world_step_compiled``,
``ratio_to_mj_step_compiled`` and ``cpu_ratio_to_mj_step_compiled`` against the bare step timed
after each of those passes (``mj_step_us_compiled_passes``, ``mj_step_cpu_us_compiled_passes``),
and ``build_s_compiled`` (or
``compiled_unavailable``: why not). The bare step is always that of world 0's model without the
plugin.
"""

from __future__ import annotations

import copy
import os
import platform
import resource
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, Callable, Sequence

import mujoco
import numpy as np
from pydantic import BaseModel
from threadpoolctl import threadpool_limits

from magsail_mj.api import load
from magsail_mj.batch import load_batch
from magsail_mj.config import ConfigError, apply_overrides, load_config, parse_config
from magsail_mj.scenario import has_compiled_loads

__all__ = ["bench", "bench_worlds", "BenchRunError", "PART_NAMES"]

PART_NAMES = ("controller", "environment", "kinematics", "probes", "recorder", "strain_check", "mj_step", "loop")
"""The parts of :func:`bench`'s breakdown besides the loads (``load: <name>``)."""

_PHYSICS = mujoco.mjtState.mjSTATE_PHYSICS


class BenchRunError(RuntimeError):
    """A benchmark pass did not complete (``status``: ``diverged``, ``failed``, ``structure_failed`` …)."""

    def __init__(self, status: str, message: str) -> None:
        super().__init__(f"the benchmarked run ended {status!r}: {message}")
        self.status = status


# ------------------------------------------------------------------------------------ inputs


def _config(config: str | Path | BaseModel, overrides: Sequence[str], duration_s: float | None) -> BaseModel:
    """The validated config with ``overrides`` and, when given, ``sim.duration_s = duration_s``."""
    extra = list(overrides) + ([f"sim.duration_s={float(duration_s)!r}"] if duration_s is not None else [])
    if isinstance(config, BaseModel):
        return parse_config(apply_overrides(config.model_dump(mode="json"), extra)) if extra else config
    return load_config(config, extra)


def _check_options(duration_s: float | None, repeat: int) -> None:
    if duration_s is not None:
        if (
            isinstance(duration_s, bool)
            or not isinstance(duration_s, (int, float))
            or not (np.isfinite(duration_s) and duration_s > 0)
        ):
            raise ValueError(f"duration_s: must be a finite number > 0 s, got {duration_s!r}")
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise ValueError(f"repeat: must be an integer >= 1, got {repeat!r}")


def _build(cfg: BaseModel) -> Any:
    """The config's stepped runner; refuses scenario kinds without one."""
    sim = load(cfg)
    missing = [a for a in ("model", "data", "run", "n_steps") if not hasattr(sim, a)]
    if missing:
        kind = f"kind {cfg.kind!r}, " if getattr(cfg, "kind", None) else ""
        raise ValueError(
            f"config: scenario {getattr(cfg, 'scenario', '?')!r} ({kind}runner {type(sim).__name__}) "
            "has no stepped MuJoCo run to benchmark"
        )
    return sim


# ------------------------------------------------------------------------------------ passes


def _timed_run(sim: Any, store: Path) -> tuple[float, float, int]:
    """``sim.run()`` streaming to ``store``: the wall seconds of its step loop (the runner's
    ``wall_time_s``), of the whole call (with the store's creation and the final read-out), and
    the steps taken."""
    t0 = time.perf_counter()
    result = sim.run(records_path=store)
    wall = time.perf_counter() - t0
    if result.status != "completed":
        raise BenchRunError(result.status, result.message)
    return float(result.wall_time_s), wall, int(result.steps)


def _bare_step_s(model: mujoco.MjModel, physics_state: np.ndarray, n: int) -> tuple[float, float, float]:
    """Seconds per bare ``mj_step`` of a model copy from ``physics_state``: per Python call (wall),
    in one native ``nstep`` call (wall), and the CPU time of the calling thread per Python call."""
    m = copy.deepcopy(model)
    d = mujoco.MjData(m)
    out = []
    for native in (False, True):
        mujoco.mj_resetData(m, d)
        mujoco.mj_setState(m, d, physics_state, _PHYSICS)
        step = mujoco.mj_step
        t0, c0 = time.perf_counter(), time.thread_time()
        if native:
            step(m, d, n)
        else:
            for _ in range(n):
                step(m, d)
        out.append((time.perf_counter() - t0) / n)
        if not native:
            cpu = (time.thread_time() - c0) / n
    return out[0], out[1], cpu


def _bare_model(sim: Any) -> mujoco.MjModel:
    """The model a bare step is timed on: without the compiled loads' plugin when it has one."""
    compiled = getattr(sim, "compiled", None)
    return compiled.bare_model if compiled is not None else sim.model


def _compiled_passes(cfg: BaseModel, tmp: Path, repeat: int) -> dict[str, Any]:
    """``us_per_step_compiled`` and its passes for a Python-path config whose scenario has compiled
    loads (``{}`` for one without; ``compiled_unavailable`` when they cannot be built)."""
    sim_cfg = getattr(cfg, "sim", None)
    if getattr(sim_cfg, "loads", None) != "python" or not has_compiled_loads(cfg):
        return {}
    try:
        compiled_cfg = parse_config(apply_overrides(cfg.model_dump(mode="json"), ["sim.loads='compiled'"]))
        runs = []
        for i in range(repeat):
            sim = _build(compiled_cfg)
            wall, _, steps = _timed_run(sim, tmp / f"compiled{i}.zarr")
            runs.append(wall / steps)
    except ConfigError as err:
        return {"compiled_unavailable": "; ".join(err.problems)}
    return {"us_per_step_compiled_runs": runs}


def _physics_state(sim: Any) -> np.ndarray:
    state = np.empty(mujoco.mj_stateSize(sim.model, _PHYSICS))
    mujoco.mj_getState(sim.model, sim.data, state, _PHYSICS)
    return state


# ------------------------------------------------------------------------------------ instrumentation


class _Clock:
    """Seconds spent per part, accumulated by wrappers."""

    def __init__(self) -> None:
        self.spent: dict[str, float] = defaultdict(float)

    def wrap(self, fn: Callable[..., Any], part: str) -> Callable[..., Any]:
        spent = self.spent
        clock = time.perf_counter

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[part] += clock() - t0

        return timed


class _TimedLoad:
    """A load whose ``add`` is timed; other attributes are the load's."""

    def __init__(self, load_: Any, clock: _Clock, part: str) -> None:
        self._load = load_
        self.add = clock.wrap(load_.add, part)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._load, name)


class _TimedCommand:
    """A held command whose ``apply_ctrl`` (when it has one) is timed as the controller's."""

    def __init__(self, cmd: Any, clock: _Clock) -> None:
        self._cmd, self._clock = cmd, clock

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._cmd, name)
        return self._clock.wrap(value, "controller") if name == "apply_ctrl" else value


class _TimedController:
    """A controller whose ``update`` is timed; a command with ``apply_ctrl`` is wrapped in a
    :class:`_TimedCommand` (one wrapper per command object, so a load that compares commands by
    identity sees the same changes), any other command is passed on as it is."""

    def __init__(self, controller: Any, clock: _Clock) -> None:
        self._controller, self._clock = controller, clock
        self._update = clock.wrap(controller.update, "controller")
        self._last: tuple[Any, Any] = (None, None)

    def update(self, state: Any) -> Any:
        cmd = self._update(state)
        if not hasattr(cmd, "apply_ctrl"):
            return cmd
        if self._last[0] is not cmd:
            self._last = (cmd, _TimedCommand(cmd, self._clock))
        return self._last[1]

    def __getattr__(self, name: str) -> Any:
        return getattr(self._controller, name)


class _TimedEnvironment:
    def __init__(self, env: Any, clock: _Clock) -> None:
        self._env = env
        self.sample = clock.wrap(env.sample, "environment")

    def __getattr__(self, name: str) -> Any:
        return getattr(self._env, name)


def _load_parts(loads: Sequence[Any]) -> list[str]:
    """``load: <name>`` per load (``#2``, ``#3`` … for repeated names)."""
    names: list[str] = []
    for ld in loads:
        base = f"load: {getattr(ld, 'name', type(ld).__name__)}"
        name, k = base, 1
        while name in names:
            k += 1
            name = f"{base} #{k}"
        names.append(name)
    return names


def _instrument(sim: Any, clock: _Clock) -> list[str]:
    """Wrap the parts the runner has (a Simulation has all, the MSAC runner a recorder); returns
    the part names."""
    parts: list[str] = []
    loads = list(getattr(sim, "loads", ()) or ())
    if loads:
        names = _load_parts(loads)
        sim.loads = [_TimedLoad(ld, clock, n) for ld, n in zip(loads, names)]
        parts += names
    if getattr(sim, "controller", None) is not None:
        sim.controller = _TimedController(sim.controller, clock)
        parts.append("controller")
    if getattr(sim, "environment", None) is not None:
        sim.environment = _TimedEnvironment(sim.environment, clock)
        parts.append("environment")
    if getattr(sim, "kin", None) is not None:
        sim.kin.update = clock.wrap(sim.kin.update, "kinematics")
        parts.append("kinematics")
    if getattr(sim, "probes", None):
        sim.probes = {k: clock.wrap(p, "probes") for k, p in sim.probes.items()}
        parts.append("probes")
    rec = getattr(sim, "recorder", None)
    if rec is not None:
        for method in ("append", "extend"):
            if hasattr(rec, method):
                setattr(rec, method, clock.wrap(getattr(rec, method), "recorder"))
        parts.append("recorder")
    if getattr(sim, "strain_check", None) is not None:
        sim.strain_check = clock.wrap(sim.strain_check, "strain_check")
        parts.append("strain_check")
    return parts + ["mj_step"]


def _parts_pass(cfg: BaseModel, store: Path) -> tuple[dict[str, float], float]:
    """The instrumented pass: µs per step of every part (``loop`` = the rest) and in all."""
    sim = _build(cfg)
    clock = _Clock()
    parts = _instrument(sim, clock)
    mj_step = mujoco.mj_step
    mujoco.mj_step = clock.wrap(mj_step, "mj_step")
    try:
        wall, _, steps = _timed_run(sim, store)
    finally:
        mujoco.mj_step = mj_step
    n = max(steps, 1)
    out = {p: clock.spent.get(p, 0.0) / n * 1e6 for p in parts}
    out["loop"] = wall / n * 1e6 - sum(out.values())
    return out, wall / n * 1e6


# ------------------------------------------------------------------------------------ entry


def bench(
    config: str | Path | BaseModel,
    *,
    overrides: Sequence[str] = (),
    duration_s: float | None = None,
    repeat: int = 1,
    worlds: int | None = None,
    nthread: int = 1,
) -> dict[str, Any]:
    """Benchmark the step loop of ``config`` (module docstring); returns a JSON-able dict.

    Args:
      config: config path, or a validated config.
      overrides: ``"key=value"`` strings as ``--set``.
      duration_s: simulated time per pass [s] (default: the config's ``sim.duration_s``).
      repeat: all-in and bare passes (medians reported); the instrumented pass runs once.
      worlds: benchmark a batch of this many identical worlds instead (:func:`bench_worlds`).
      nthread: the batch's threads (with ``worlds``).

    Raises:
      ValueError: a bad option (named), or a scenario kind without a stepped run (``config``);
      ConfigError: the config with the overrides is invalid (or cannot run in a batch);
      BenchRunError: a pass did not complete (diverged, failed).
    """
    if worlds is not None:
        return bench_worlds(
            config, overrides=overrides, duration_s=duration_s, repeat=repeat, worlds=worlds, nthread=nthread
        )
    _check_options(duration_s, repeat)
    cfg = _config(config, overrides, duration_s)
    with threadpool_limits(limits=1), tempfile.TemporaryDirectory(prefix="magsail_bench_") as tmp:
        all_in, bare, native, setup = [], [], [], []
        for i in range(repeat):
            sim = _build(cfg)
            physics = _physics_state(sim)
            wall, call, steps = _timed_run(sim, Path(tmp) / f"pass{i}.zarr")
            all_in.append(wall / steps)
            setup.append(call - wall)
            per_call, per_native, _ = _bare_step_s(_bare_model(sim), physics, steps)
            bare.append(per_call)
            native.append(per_native)
        model = sim.model
        del sim
        compiled = _compiled_passes(cfg, Path(tmp), repeat)
        parts, instrumented = _parts_pass(cfg, Path(tmp) / "parts.zarr")
    return _report(
        cfg,
        model,
        steps=steps,
        all_in=all_in,
        bare=bare,
        native=native,
        parts=parts,
        instrumented_us=instrumented,
        setup_s=statistics.median(setup),
        compiled=compiled,
    )


def _report(
    cfg: BaseModel,
    model: mujoco.MjModel,
    *,
    steps: int,
    all_in: list[float],
    bare: list[float],
    native: list[float],
    parts: dict[str, float],
    instrumented_us: float,
    setup_s: float,
    compiled: dict[str, Any],
) -> dict[str, Any]:
    us = statistics.median(all_in) * 1e6
    mj_us = statistics.median(bare) * 1e6
    extra: dict[str, Any] = {}
    if "us_per_step_compiled_runs" in compiled:
        runs = compiled["us_per_step_compiled_runs"]
        us_c = statistics.median(runs) * 1e6
        extra = {
            "us_per_step_compiled": us_c,
            "ratio_to_mj_step_compiled": us_c / mj_us,
            "us_per_step_compiled_runs": [x * 1e6 for x in runs],
        }
    elif compiled:
        extra = dict(compiled)
    dt = float(model.opt.timestep)
    integrator = mujoco.mjtIntegrator(model.opt.integrator).name.removeprefix("mjINT_")
    return {
        "concept": getattr(cfg, "concept", None),
        "scenario": getattr(cfg, "scenario", None),
        "kind": getattr(cfg, "kind", None),
        "steps": steps,
        "timestep_s": dt,
        "integrator": integrator,
        "duration_s": steps * dt,
        "repeat": len(all_in),
        "loads": getattr(getattr(cfg, "sim", None), "loads", "python"),
        "us_per_step": us,
        "mj_step_us": mj_us,
        "ratio_to_mj_step": us / mj_us,
        **extra,
        "mj_step_native_us": statistics.median(native) * 1e6,
        "parts_us": parts,
        "instrumented_us_per_step": instrumented_us,
        "run_setup_s": setup_s,
        "steps_per_s": 1e6 / us,
        "realtime_factor": dt / (us * 1e-6),
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "us_per_step_runs": [x * 1e6 for x in all_in],
        "mj_step_us_runs": [x * 1e6 for x in bare],
        "platform": _platform(),
    }


def _platform() -> dict[str, Any]:
    """The versions and the machine a benchmark ran on."""
    return {
        "python": platform.python_version(),
        "mujoco": mujoco.__version__,
        "numpy": np.__version__,
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "system": sys.platform,
    }


def _batch_passes(cfg: BaseModel, *, worlds: int, nthread: int, repeat: int, tmp: Path, tag: str) -> dict[str, Any]:
    """``repeat`` fresh batches of ``worlds`` identical worlds of ``cfg`` run to the end, each world's
    records streamed to a store under ``tmp``, and after each the bare ``mj_step`` of world 0's
    model without compiled loads from its initial state: the per-world-step wall and CPU seconds,
    the bare step (per call and native), the build seconds, the steps and the model stepped bare.

    Raises:
      BenchRunError: a world of a pass did not complete."""
    out: dict[str, Any] = {"wall": [], "cpu": [], "bare": [], "bare_cpu": [], "native": [], "build": []}
    for i in range(repeat):
        t0 = time.perf_counter()
        sim = load_batch(cfg, worlds=worlds, nthread=nthread)
        out["build"].append(time.perf_counter() - t0)
        stores = [tmp / f"{tag}{i}_world{k}.zarr" for k in range(worlds)]
        c0 = time.process_time()
        result = sim.run(records_paths=stores)
        cpu_s = time.process_time() - c0
        bad = [(k, w.status, w.message) for k, w in enumerate(result.worlds) if w.status != "completed"]
        if bad:
            k, status, message = bad[0]
            raise BenchRunError(status, f"world {k}: {message}")
        out["wall"].append(result.wall_time_s / result.world_steps)
        out["cpu"].append(cpu_s / result.world_steps)
        bare_model = getattr(sim.worlds, "bare_model", sim.model)
        physics = np.empty(mujoco.mj_stateSize(bare_model, _PHYSICS))
        data = mujoco.MjData(bare_model)
        sim.worlds.init_state(0, data)
        mujoco.mj_getState(bare_model, data, physics, _PHYSICS)
        per_call, per_native, per_call_cpu = _bare_step_s(bare_model, physics, sim.n_steps)
        out["bare"].append(per_call)
        out["bare_cpu"].append(per_call_cpu)
        out["native"].append(per_native)
        out["steps"], out["model"] = sim.n_steps, bare_model
        del sim, result
    return out


def bench_worlds(
    config: str | Path | BaseModel,
    *,
    worlds: int,
    nthread: int = 1,
    overrides: Sequence[str] = (),
    duration_s: float | None = None,
    repeat: int = 1,
) -> dict[str, Any]:
    """Benchmark a batch of ``worlds`` identical worlds of ``config`` on ``nthread`` threads against
    the bare ``mj_step`` of its model (module docstring); returns a JSON-able dict.

    Raises:
      ValueError: a bad option (named);
      ConfigError: the config is invalid or cannot run in a batch (the key named);
      BenchRunError: a world of a pass did not complete.
    """
    _check_options(duration_s, repeat)
    if isinstance(worlds, bool) or not isinstance(worlds, int) or worlds < 1:
        raise ValueError(f"worlds: must be an integer >= 1, got {worlds!r}")
    cfg = _config(config, overrides, duration_s)
    options = {"worlds": worlds, "nthread": nthread, "repeat": repeat}
    compiled: dict[str, Any] = {}
    with threadpool_limits(limits=1), tempfile.TemporaryDirectory(prefix="magsail_bench_") as tmp:
        runs = _batch_passes(cfg, tmp=Path(tmp), tag="pass", **options)
        if getattr(getattr(cfg, "sim", None), "loads", None) == "python" and has_compiled_loads(cfg):
            try:
                compiled_cfg = parse_config(apply_overrides(cfg.model_dump(mode="json"), ["sim.loads='compiled'"]))
                c = _batch_passes(compiled_cfg, tmp=Path(tmp), tag="compiled", **options)
            except ConfigError as err:
                compiled = {"compiled_unavailable": "; ".join(err.problems)}
            else:
                us_c, cpu_c, mj_c, mj_cpu_c = (
                    statistics.median(c[x]) * 1e6 for x in ("wall", "cpu", "bare", "bare_cpu")
                )
                compiled = {
                    "us_per_world_step_compiled": us_c,
                    "cpu_us_per_world_step_compiled": cpu_c,
                    "mj_step_us_compiled_passes": mj_c,
                    "mj_step_cpu_us_compiled_passes": mj_cpu_c,
                    "ratio_to_mj_step_compiled": us_c / mj_c,
                    "cpu_ratio_to_mj_step_compiled": cpu_c / mj_cpu_c,
                    "build_s_compiled": statistics.median(c["build"]),
                    "us_per_world_step_compiled_runs": [x * 1e6 for x in c["wall"]],
                }
    us, cpu_us, mj_us, mj_cpu_us = (statistics.median(runs[x]) * 1e6 for x in ("wall", "cpu", "bare", "bare_cpu"))
    steps, model = runs["steps"], runs["model"]
    dt = float(model.opt.timestep)
    return {
        "concept": getattr(cfg, "concept", None),
        "scenario": getattr(cfg, "scenario", None),
        "kind": getattr(cfg, "kind", None),
        "steps": steps,
        "timestep_s": dt,
        "integrator": mujoco.mjtIntegrator(model.opt.integrator).name.removeprefix("mjINT_"),
        "duration_s": steps * dt,
        "repeat": repeat,
        "worlds": worlds,
        "nthread": nthread,
        "loads": getattr(getattr(cfg, "sim", None), "loads", None),
        "us_per_world_step": us,
        "cpu_us_per_world_step": cpu_us,
        "mj_step_us": mj_us,
        "mj_step_cpu_us": mj_cpu_us,
        "ratio_to_mj_step": us / mj_us,
        "cpu_ratio_to_mj_step": cpu_us / mj_cpu_us,
        "mj_step_native_us": statistics.median(runs["native"]) * 1e6,
        "build_s": statistics.median(runs["build"]),
        "us_per_world_step_runs": [x * 1e6 for x in runs["wall"]],
        "mj_step_us_runs": [x * 1e6 for x in runs["bare"]],
        **compiled,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "platform": _platform(),
    }
