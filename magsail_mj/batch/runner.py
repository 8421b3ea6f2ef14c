r"""The batch runner: N worlds of one compiled model stepped in lockstep, one Python step for all.

:class:`BatchSimulation` is :class:`magsail_mj.sim.Simulation` over a world axis. Each step ``k``
(``t = k·δt``), for every live world at once:

1. the plant's controller samples what is due and writes ``ctrl`` (:meth:`control`);
2. every ``record_every`` steps (and at the end) the probes are recorded, before the step, so
   record 0 is the initial state (:class:`~magsail_mj.batch.records.WorldRecords`);
3. the plant's loads write ``xfrc_applied`` (:meth:`loads`);
4. :meth:`mujoco.batch.Batch.step` advances the live worlds by one ``mj_step`` each, on
   ``nthread`` threads (bit-identical to a loop over one ``MjData`` per world at any thread count);
5. each stepped world is checked as the single run checks its state
   (:mod:`magsail_mj.divergence`: MuJoCo's automatic reset is off; a bad-state warning of this step
   dates the bad state at t, a ``qpos``/``qvel`` that is not finite at t + δt); a MuJoCo error in
   a world's step makes it ``failed``.

With a plant whose loads are inside MuJoCo's step (``native_steps``: compiled loads, each world on
a model with the plugin, e.g. :class:`~magsail_mj.concepts.cnusail.batch_compiled.CompiledCubesatWorlds`)
Python acts only at the controller's samples (every ``plant.control_every`` steps: :meth:`control`,
which writes the plugin's state) and the records; every live world is stepped natively to the next
such step in one :meth:`mujoco.batch.Batch.step` call of ``nstep`` steps (never :meth:`loads`). A
world that went bad in such a chunk (a MuJoCo error, a bad-state warning, a state that is not
finite) is put back to the chunk's start and stepped again one step at a time with the checks
below, so it is dated at the same step, with the same status and message, as its single run with
compiled loads dates it.

A world whose stop rule holds (:class:`HoldBelowWorlds`, checked after each record as the single
run's :class:`~magsail_mj.sim.HoldBelow`) ends alone there, ``completed`` with its single run's
message and end time, and is not stepped again.

A world that goes bad stops alone: its status (``diverged``, ``failed``), message and time are its
own, its records stop where its single run's would (a record of a state MuJoCo flagged is dropped),
its MuJoCo state and controller state stay as they were, and it is not stepped again; the others
go on. Statuses are those of :class:`~magsail_mj.sim.RunResult` (``running``, ``completed``,
``diverged``, ``failed``, ``stopped``, ``interrupted``).

:meth:`get_state` / :meth:`set_state` hold the whole batch as plain data (every world's MuJoCo
integration state, the plant's Python-side state, the statuses and record counts); continuing from
a state gives the same numbers, bit for bit, as the run that followed it. :meth:`run` writes that
state to a checkpoint file every ``checkpoint_every_s`` and resumes from one
(:mod:`magsail_mj.batch.checkpoint`: one data-only file for the whole batch, with each world's
identity and record count; the records stay in each world's store).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Protocol, Sequence

import numpy as np
from mujoco.batch import Batch, SimulationError

from magsail_mj.batch.checkpoint import restore_batch_checkpoint, write_batch_checkpoint
from magsail_mj.batch.records import WorldRecords
from magsail_mj.divergence import BAD_STATE_WARNINGS
from magsail_mj.sim import RunResult, _non_finite_records, progress_bar, vector_norm

__all__ = ["BatchSimulation", "BatchResult", "Plant", "HoldBelowWorlds"]

_WARNINGS = [(int(w), w.name.removeprefix("mjWARN_"), text) for w, text in BAD_STATE_WARNINGS.items()]


class Plant(Protocol):
    """What the runner needs from a concept's part of a batch (e.g.
    :class:`~magsail_mj.concepts.cnusail.batch_plant.CubesatWorlds`). Optional: ``attach(batch)``
    (called once with the :class:`mujoco.batch.Batch`), ``native_steps = True`` with
    ``control_every`` [steps] for loads inside MuJoCo's step (module docstring), and
    ``failures(step, qpos, live)`` → ``{world: message}``, checked after each record of the Python
    loop (those worlds stop, ``structure_failed``: a truss strut beyond its strain bound), and
    ``control_failures()`` → ``{world: message}``, checked after each :meth:`control` (those worlds
    stop, ``failed``: a user's control law that raised)."""

    probe_names: Sequence[str]

    def control(self, step: int, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray) -> None: ...

    def probes(self, step: int, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]: ...

    def loads(self, step: int, qpos: np.ndarray, qvel: np.ndarray, xfrc: np.ndarray) -> None: ...

    def set_live(self, live: np.ndarray) -> None: ...

    def reset(self) -> None: ...

    def get_state(self) -> dict[str, Any]: ...

    def set_state(self, state: dict[str, Any]) -> None: ...


class HoldBelowWorlds:
    """Each world's stop rule over the world axis: :class:`magsail_mj.sim.HoldBelow` with a
    threshold, hold time and description per world (a world without a rule has threshold −∞, so
    never stops by it), evaluated on the record's ``(N, …)`` values with the single run's
    arithmetic (:func:`~magsail_mj.sim.vector_norm`), so a world stops at its single run's record.

    Args:
      probe, index: the recorded variable and its components (as ``HoldBelow``).
      thresholds: (N,) in the probe's unit (−∞: no rule); holds_s: (N,) [s]; tolerance_s: [s].
      describe: per world, the rule's text for the message (``""`` without a rule).
    """

    def __init__(
        self,
        *,
        probe: str,
        index: slice,
        thresholds: np.ndarray,
        holds_s: np.ndarray,
        tolerance_s: float,
        describe: Sequence[str],
    ) -> None:
        self.probe, self.index = probe, index
        self.thresholds = np.asarray(thresholds, dtype=float)
        self.holds_s = np.asarray(holds_s, dtype=float)
        self.tolerance_s = float(tolerance_s)
        self.describe = list(describe)
        self.below_since_s = np.full(self.thresholds.shape, np.nan)  # NaN: the last record was not below

    def check(self, t: float, values: Mapping[str, np.ndarray], live: np.ndarray) -> dict[int, str]:
        """The record at ``t`` [s] of every world: world → its end message, for the live worlds that
        the rule ends here."""
        s = vector_norm(np.asarray(values[self.probe])[:, self.index])
        below = s < self.thresholds
        since = self.below_since_s
        since[~below] = np.nan
        since[below & np.isnan(since)] = t
        done = live & below & (t - since >= self.holds_s - self.tolerance_s)
        return {
            k: f"{self.describe[k]}: held from t = {since[k]:.6g} s; the run ended at t = {t:.6g} s"
            for k in np.flatnonzero(done).tolist()
        }


@dataclass
class BatchResult:
    """What a batch run produced: ``worlds[k]`` is world k's :class:`~magsail_mj.sim.RunResult`
    (its records, status, message, end time, steps, and its share of the wall time: the batch's
    step-loop wall time in proportion to the steps it took); ``wall_time_s`` [s] and
    ``world_steps`` are the whole batch's."""

    worlds: list[RunResult]
    wall_time_s: float
    world_steps: int

    @property
    def status(self) -> list[str]:
        """Each world's status."""
        return [w.status for w in self.worlds]


class BatchSimulation:
    """N worlds of one model, stepped together (module docstring).

    Args:
      batch: the MuJoCo batch (its model's automatic reset switched off, per-world model fields
        expanded).
      plant: the concept's part (controller, loads, probes over the world axis).
      duration_s: simulated time of every world [s].
      record_every: decimation of the records.
      initial_state: (N, nstate) every world's MuJoCo integration state at t = 0.
      stop_rule: the worlds' stop rules (:class:`HoldBelowWorlds`), or ``None``.

    Attributes set by :func:`magsail_mj.batch.load_batch`: ``cfgs`` (each world's validated
    config), ``worlds`` (the concept's built worlds: ``scenario(k)`` gives world k's task),
    ``identities`` (each world's run identity).
    """

    streams_records = True

    def __init__(
        self,
        *,
        batch: Batch,
        plant: Plant,
        duration_s: float,
        record_every: int,
        initial_state: np.ndarray,
        stop_rule: HoldBelowWorlds | None = None,
    ) -> None:
        if record_every < 1:
            raise ValueError(f"record_every: must be >= 1, got {record_every}")
        self.batch = batch
        self.model = batch.model
        self.plant = plant
        self.stop_rule = stop_rule
        self.n_worlds = int(batch.nsim)
        self.dt = float(self.model.opt.timestep)
        self.duration_s = float(duration_s)
        self.n_steps = int(round(duration_s / self.dt))
        self.record_every = int(record_every)
        state = np.asarray(initial_state, dtype=float)
        if state.shape != batch.state.shape:
            raise ValueError(f"initial_state: shape {state.shape}, the batch holds {batch.state.shape}")
        batch.state[...] = state
        self._qpos, self._qvel = batch.bind("qpos"), batch.bind("qvel")
        self._ctrl, self._xfrc = batch.bind("ctrl"), batch.bind("xfrc_applied")
        self._warn_idx = np.array([w for w, _, _ in _WARNINGS])
        if hasattr(plant, "attach"):
            plant.attach(batch)
        self.native = bool(getattr(plant, "native_steps", False))
        self.recorded = WorldRecords(["t", *plant.probe_names], self.n_worlds)
        self.cfgs: list[Any] = []
        self.worlds: Any = None
        self.identities: list[dict[str, Any]] = []
        self._begin(0)
        self._initial = self.get_state()

    # ------------------------------------------------------------------ bookkeeping
    def _begin(self, step: int) -> None:
        n = self.n_worlds
        self.step_index = step
        self.live = np.ones(n, dtype=bool)
        self.plant.set_live(self.live)
        self.status = ["running"] * n
        self.message = [""] * n
        self.end_step = np.full(n, step, dtype=np.int64)
        self._wall_s = 0.0
        self._world_steps = np.zeros(n, dtype=np.int64)
        self._warn_base = self._warnings()

    def _warnings(self) -> np.ndarray:
        """(N, 4) counts of MuJoCo's bad-state warnings of every world."""
        return self.batch.warning[:, self._warn_idx, 1].copy()

    @property
    def time(self) -> float:
        """Simulated time of the batch's current step [s] (``step_index · δt``)."""
        return self.step_index * self.dt

    def records(self, world: int) -> Mapping[str, np.ndarray]:
        """World ``world``'s records so far (``t`` and every probe, stacked over record times)."""
        self.recorded.flush(self.live)
        return self.recorded.recorders[world].arrays()

    @property
    def recorders(self) -> list[Any]:
        """Each world's :class:`~magsail_mj.records.Recorder`."""
        return self.recorded.recorders

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """The whole batch as plain data: the step, every world's MuJoCo integration state (``mj_state``,
        (N, nstate)), which worlds run, their statuses, messages and end steps, their record counts,
        and the plant's Python-side state."""
        self.recorded.flush(self.live)
        return {
            "step": self.step_index,
            "mj_state": self.batch.state.copy(),
            "live": self.live.copy(),
            "status": list(self.status),
            "message": list(self.message),
            "end_step": self.end_step.copy(),
            "n_records": self.recorded.counts(),
            "plant": self.plant.get_state(),
            "stop_since_s": None if self.stop_rule is None else self.stop_rule.below_since_s.copy(),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state` (of this batch or one built from the same
        configs): the following steps equal those that followed the state's own. Records made after
        it are dropped; the worlds that ran then run again (status ``running``), the others keep the
        status they had."""
        mj_state = np.asarray(state["mj_state"], dtype=float)
        if mj_state.shape != self.batch.state.shape:
            raise ValueError(f"state: 'mj_state' has shape {mj_state.shape}, this batch {self.batch.state.shape}")
        step = int(state["step"])
        if not 0 <= step <= self.n_steps:
            raise ValueError(f"state: step {step} is outside 0 … {self.n_steps}")
        self.batch.state[...] = mj_state
        self.plant.set_state(state["plant"])
        if self.stop_rule is not None:
            self.stop_rule.below_since_s[...] = state["stop_since_s"]
        self.recorded.flush(self.live)
        for rec, keep in zip(self.recorded.recorders, np.asarray(state["n_records"]).tolist()):
            rec.truncate(min(int(keep), len(rec)))
        self.step_index = step
        self.live = np.array(state["live"], dtype=bool, copy=True)
        self.plant.set_live(self.live)
        self.status = ["running" if ok else s for ok, s in zip(self.live.tolist(), state["status"])]
        self.message = ["" if ok else m for ok, m in zip(self.live.tolist(), state["message"])]
        self.end_step = np.array(state["end_step"], dtype=np.int64, copy=True)
        self.end_step[self.live] = step
        self._warn_base = self._warnings()

    def reset(self, *, seed: int | None = None) -> None:
        """Back to the initial state of the build (t = 0, no records) in every world. ``seed`` is
        accepted for :meth:`magsail_mj.sim.Simulation.reset`'s interface; the batch's scenarios
        hold no random generator, so it changes nothing."""
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ValueError(f"seed: must be an integer >= 0 or None, got {seed!r}")
        self.set_state(self._initial)
        for rec in self.recorded.recorders:
            rec.truncate(0)
        self._begin(0)

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> list[str]:
        """Advance ``n`` steps (never beyond ``duration_s``); return every world's status."""
        if int(n) != n or n < 1:
            raise ValueError(f"n: must be an integer >= 1, got {n!r}")
        if self.live.any():
            self._advance(min(self.step_index + int(n), self.n_steps))
        return list(self.status)

    def run(
        self,
        *,
        progress: bool = False,
        stop_after_s: float | None = None,
        records_paths: Sequence[str | Path] | None = None,
        records_attrs: Sequence[dict[str, Any] | None] | None = None,
        checkpoint_path: str | Path | None = None,
        checkpoint_every_s: float = 0.0,
        resume: bool = False,
    ) -> BatchResult:
        """Run every live world from the current state to ``duration_s`` (or until it stops, an
        interrupt, or ``stop_after_s``).

        ``records_paths`` (one per world) streams each world's records to its Zarr store, with
        ``records_attrs[k]`` as its attributes (as :meth:`Simulation.run`'s ``records_path``).

        ``checkpoint_path`` (with ``records_paths``): the batch checkpoint
        (:mod:`magsail_mj.batch.checkpoint`) is written there at every step that is a multiple of
        ``checkpoint_every_s`` [s] (0: none) and at ``stop_after_s``, as a single run's is; with
        ``resume`` the batch (freshly built from the same configs) first continues from it, its
        stores cut to the file's record counts. A resumed world's ``wall_time_s`` includes the
        checkpointed batch's, as a resumed single run's does."""
        if checkpoint_path is not None and records_paths is None:
            raise ValueError("checkpoint_path: a batch checkpoint needs the worlds' record stores (records_paths)")
        if resume and checkpoint_path is None:
            raise ValueError("resume: needs the checkpoint_path to resume from")
        if not (checkpoint_every_s >= 0.0 and math.isfinite(checkpoint_every_s)):
            raise ValueError(f"checkpoint_every_s: must be a finite number >= 0 [s], got {checkpoint_every_s!r}")
        if resume:
            restore_batch_checkpoint(self, Path(checkpoint_path), list(records_paths))
        elif records_paths is not None:
            attrs = list(records_attrs) if records_attrs is not None else [None] * len(records_paths)
            self.recorded.create_stores(list(records_paths), attrs)
        start = self.step_index
        steps0 = np.zeros_like(self._world_steps) if resume else self._world_steps.copy()
        wall0 = 0.0 if resume else self._wall_s
        stop_step = self.n_steps if stop_after_s is None else min(self.n_steps, int(round(stop_after_s / self.dt)))
        bar = progress_bar(total=self.n_steps, initial=start, mininterval_s=1.0) if progress else None
        ckpt = Path(checkpoint_path) if checkpoint_path is not None else None
        every = int(round(checkpoint_every_s / self.dt)) if checkpoint_every_s > 0 and ckpt is not None else 0
        try:
            self._advance_checkpointed(stop_step, ckpt=ckpt, every=every, bar=bar)
        finally:
            if bar is not None:
                bar.close()
        for k in np.flatnonzero(self.live):
            if self.status[k] == "running":  # stop_after_s reached before the end
                self.status[k], self.message[k] = "stopped", f"stopped at t = {self.time:.6g} s (stop_after_s)"
        for k, rec in enumerate(self.recorded.recorders):
            if self.status[k] == "completed":
                self.status[k], self.message[k] = _non_finite_records(rec) or (self.status[k], self.message[k])
        wall = self._wall_s - wall0
        total = int((self._world_steps - steps0).sum())
        # each world as a single run counts it: every step from t = 0 and its share of the loops'
        # wall time so far (a resumed batch's earlier calls included)
        all_steps = int(self._world_steps.sum())
        worlds = [
            RunResult(
                records=rec.arrays(),
                status=self.status[k],
                message=self.message[k],
                t_end_s=float(self.end_step[k]) * self.dt,
                steps=int(self.end_step[k]),
                wall_time_s=self._wall_s * float(self._world_steps[k]) / all_steps if all_steps else 0.0,
            )
            for k, rec in enumerate(self.recorded.recorders)
        ]
        return BatchResult(worlds=worlds, wall_time_s=wall, world_steps=total)

    def _advance_checkpointed(self, stop_step: int, *, ckpt: Path | None, every: int, bar: Any) -> None:
        """:meth:`_advance` to ``stop_step`` in pieces that end at the checkpoint steps (multiples of
        ``every``, and ``stop_step`` before the end), writing the checkpoint ``ckpt`` at each (at
        the top of the step, before its controller sample and record, as a single run does). The
        loops end a piece at its step exactly where they would pass it, so the numbers do not depend
        on the pieces; an interrupt while a checkpoint is written (kept whole: it is replaced
        atomically) stops the running worlds as one in a step would."""
        while self.live.any():
            target = stop_step if not every else min(stop_step, (self.step_index // every + 1) * every)
            self._advance(target, bar=bar)
            if ckpt is None or self.step_index != target or not self.live.any() or target == self.n_steps:
                break
            if (every and target % every == 0) or target == stop_step:
                wall0 = time.perf_counter()
                try:
                    write_batch_checkpoint(self, ckpt)
                except KeyboardInterrupt:
                    for k in np.flatnonzero(self.live):
                        self.status[k], self.message[k] = "interrupted", f"interrupted at t = {self.time:.6g} s"
                    self.live[:] = False
                    self.plant.set_live(self.live)
                finally:
                    self._wall_s += time.perf_counter() - wall0
            if target == stop_step:
                break

    def _advance(self, stop_step: int, *, bar: Any = None) -> None:
        """The lockstep loop from the current step to ``stop_step`` (module docstring)."""
        if self.native:
            self._advance_native(stop_step, bar=bar)
            return
        plant, rec, b = self.plant, self.recorded, self.batch
        qpos, qvel, ctrl, xfrc = self._qpos, self._qvel, self._ctrl, self._xfrc
        dt, n = self.dt, self.n_worlds
        start = step = self.step_index
        finished = np.zeros(n, dtype=bool)  # worlds that complete or are interrupted in this call
        wall0 = time.perf_counter()
        try:
            with np.errstate(all="ignore"):  # a stopped world's numbers may be NaN; it is not stepped
                self._check(step, stepped=None)
                for step in range(start, stop_step + 1):
                    if step == stop_step < self.n_steps or not self.live.any():
                        break
                    t = step * dt
                    plant.control(step, qpos, qvel, ctrl)
                    if self._control_failures(step):
                        break
                    if step % self.record_every == 0 or step == self.n_steps:
                        values = plant.probes(step, qpos, qvel)
                        values["t"] = np.full(n, t)
                        rec.append(values, self.live)
                        if self._structure_failures(step):
                            break
                        if self.stop_rule is not None:
                            ends = self.stop_rule.check(t, values, self.live)
                            self._stop(np.array(list(ends), dtype=np.intp), step, "completed", ends.__getitem__)
                            if not self.live.any():
                                break
                    if step == self.n_steps:
                        finished = self.live.copy()
                        for k in np.flatnonzero(finished):
                            self.status[k] = "completed"
                        break
                    plant.loads(step, qpos, qvel, xfrc)
                    stepped = self.live.copy()
                    ids = None if stepped.all() else np.flatnonzero(stepped).astype(np.int32)
                    try:
                        b.step(ids)
                    except SimulationError as err:
                        self._stop(err.ids, step, "failed", lambda k: f"MuJoCo error at t = {t:.6g} s: {b.error(k)}")
                        stepped[err.ids] = False
                    self._world_steps += stepped
                    self._check(step, stepped=stepped)
                    if bar is not None and (step + 1) % 100 == 0:
                        bar.update(100)
        except KeyboardInterrupt:
            finished = self.live.copy()
            for k in np.flatnonzero(finished):
                self.status[k], self.message[k] = "interrupted", f"interrupted at t = {step * dt:.6g} s"
        finally:
            self._end_loop(step, finished, wall0)

    def _end_loop(self, step: int, finished: np.ndarray, wall0: float) -> None:
        """After a step loop stopped at ``step``: the worlds that ended there (the live ones and
        ``finished``, those that completed or were interrupted) get their end step and their records
        flushed, the finished ones stop, and the loop's wall time since ``wall0`` is counted."""
        self.step_index = step
        ended = self.live | finished
        self.end_step[ended] = step
        self.recorded.flush(ended)
        if finished.any():
            self.live[finished] = False
            self.plant.set_live(self.live)
        self._wall_s += time.perf_counter() - wall0

    def _advance_native(self, stop_step: int, *, bar: Any = None) -> None:
        """The loop with the loads inside MuJoCo's step (module docstring): Python at the
        controller's samples (``step % plant.control_every == 0``) and the records only, every
        live world stepped natively to the next such step in one call."""
        plant, rec = self.plant, self.recorded
        qpos, qvel, ctrl = self._qpos, self._qvel, self._ctrl
        dt, n, every = self.dt, self.n_worlds, self.record_every
        control_every = int(plant.control_every)
        step = self.step_index
        finished = np.zeros(n, dtype=bool)
        pending = 0
        wall0 = time.perf_counter()
        try:
            with np.errstate(all="ignore"):
                self._check(step, stepped=None)
                while True:
                    if step == stop_step < self.n_steps or not self.live.any():
                        break
                    if step % control_every == 0:
                        plant.control(step, qpos, qvel, ctrl)
                        if self._control_failures(step):
                            break
                    if step % every == 0 or step == self.n_steps:
                        values = plant.probes(step, qpos, qvel)
                        values["t"] = np.full(n, step * dt)
                        rec.append(values, self.live)
                        if self.stop_rule is not None:
                            ends = self.stop_rule.check(step * dt, values, self.live)
                            self._stop(np.array(list(ends), dtype=np.intp), step, "completed", ends.__getitem__)
                            if not self.live.any():
                                break
                    if step == self.n_steps:
                        finished = self.live.copy()
                        for k in np.flatnonzero(finished):
                            self.status[k] = "completed"
                        break
                    next_record, next_sample = (step // every + 1) * every, (step // control_every + 1) * control_every
                    nxt = min(stop_step, self.n_steps, next_record, next_sample)
                    self._chunk(step, nxt)
                    pending += nxt - step
                    step = nxt
                    if bar is not None and pending >= 100:
                        bar.update(pending)
                        pending = 0
        except KeyboardInterrupt:
            finished = self.live.copy()
            for k in np.flatnonzero(finished):
                self.status[k], self.message[k] = "interrupted", f"interrupted at t = {step * dt:.6g} s"
        finally:
            self._end_loop(step, finished, wall0)

    def _chunk(self, first: int, last: int) -> None:
        """Step every live world from step ``first`` to ``last`` in one native call. A world that
        went bad in it (a MuJoCo error, a bad-state warning, a state that is not finite) is put back
        to its state at ``first`` and stepped again one step at a time with the checks of the
        lockstep loop, so it stops at the same step, with the same status and message, as there;
        one that does not go bad again is stopped as the single run stops it."""
        b = self.batch
        live = self.live.copy()
        ids = None if live.all() else np.flatnonzero(live).astype(np.int32)
        snapshot = b.state.copy()
        failed = np.zeros(self.n_worlds, dtype=bool)
        try:
            b.step(ids, last - first)
        except SimulationError as err:
            failed[err.ids] = True
        counts = self._warnings()
        bad = failed.copy()
        if not np.array_equal(counts, self._warn_base):
            bad |= (counts > self._warn_base).any(axis=1) & live
        qpos, qvel = (self._qpos, self._qvel) if ids is None else (self._qpos[live], self._qvel[live])
        if not math.isfinite(float(qpos.sum()) + float(qvel.sum())):
            bad |= live & ~np.isfinite(self._qpos.sum(axis=1) + self._qvel.sum(axis=1))
        self._world_steps += (live & ~bad) * (last - first)
        if not bad.any():
            return
        rows = np.flatnonzero(bad)
        b.state[rows] = snapshot[rows]
        self._warn_base[rows] = counts[rows]  # the chunk's warnings are raised again by the replay
        for step in range(first, last):
            stepped = bad & self.live
            if not stepped.any():
                return
            t = step * self.dt
            try:
                b.step(np.flatnonzero(stepped).astype(np.int32))
            except SimulationError as err:
                self._stop(err.ids, step, "failed", lambda k: f"MuJoCo error at t = {t:.6g} s: {b.error(k)}")
                stepped[err.ids] = False
            self._world_steps += stepped
            self._check(step, stepped=stepped)
        again = np.flatnonzero(bad & self.live)
        self._stop(
            again,
            last - 1,
            "diverged",
            lambda k: (
                f"MuJoCo flagged the steps from t = {first * self.dt:.6g} s to {last * self.dt:.6g} s, "
                "which did not go bad again when repeated one by one"
            ),
            t_bad_s=first * self.dt,
        )

    def _check(self, step: int, *, stepped: np.ndarray | None) -> None:
        """Stop the worlds whose state went bad in the step from ``step`` (``stepped``: the worlds
        stepped; ``None``: only the warnings raised before the loop, dated at ``step``)."""
        t = step * self.dt
        counts = self._warnings()
        if np.array_equal(counts, self._warn_base):
            if stepped is None:
                return
            qpos, qvel = (self._qpos, self._qvel) if stepped.all() else (self._qpos[stepped], self._qvel[stepped])
            if math.isfinite(float(qpos.sum()) + float(qvel.sum())):
                return  # the usual step: no warning, every stepped world finite
        raised = (counts > self._warn_base) & self.live[:, None]
        bad_warn = raised.any(axis=1)
        bad_state = np.zeros_like(bad_warn)
        if stepped is not None:
            finite = np.isfinite(self._qpos.sum(axis=1) + self._qvel.sum(axis=1))
            bad_state = stepped & ~finite & ~bad_warn
        if not (bad_warn.any() or bad_state.any()):
            return
        first = np.argmax(raised, axis=1)

        def warn_message(k: int) -> str:
            _, name, text = _WARNINGS[int(first[k])]
            return f"MuJoCo {name} at t = {t:.6g} s: {text}"

        self._stop(np.flatnonzero(bad_warn), step, "diverged", warn_message, t_bad_s=t)
        self._stop(
            np.flatnonzero(bad_state),
            step,
            "diverged",
            lambda k: f"state is not finite at t = {t + self.dt:.6g} s (after the step from t = {t:.6g} s)",
        )

    def _structure_failures(self, step: int) -> bool:
        """Stop the live worlds whose structure failed at the record of ``step`` (the plant's optional
        ``failures(step, qpos, live)``: world → message), ``structure_failed`` with the record kept,
        as the single run's strain check; return whether no world is left running."""
        check = getattr(self.plant, "failures", None)
        if check is not None:
            fails = check(step, self._qpos, self.live)
            self._stop(np.array(list(fails), dtype=np.intp), step, "structure_failed", fails.__getitem__)
        return not self.live.any()

    def _control_failures(self, step: int) -> bool:
        """Stop the live worlds whose controller failed at step ``step`` (the plant's optional
        ``control_failures()``: world → message), ``failed`` with their records so far kept; return
        whether no world is left running."""
        take = getattr(self.plant, "control_failures", None)
        if take is not None:
            fails = {k: m for k, m in take().items() if self.live[k]}
            self._stop(np.array(list(fails), dtype=np.intp), step, "failed", fails.__getitem__)
        return not self.live.any()

    def _stop(self, worlds: np.ndarray, step: int, status: str, message: Any, *, t_bad_s: float | None = None) -> None:
        """Stop ``worlds`` at ``step`` with ``status`` and ``message(k)``; with ``t_bad_s`` their
        records from that time on are dropped (a record of a state MuJoCo flagged is not a number)."""
        if not len(worlds):
            return
        self.recorded.flush(self.live)
        for k in np.asarray(worlds).tolist():
            self.status[k], self.message[k] = status, message(k)
            self.end_step[k] = step
            if t_bad_s is not None:
                rec = self.recorded.recorders[k]
                rec.truncate(int(np.searchsorted(rec.column("t"), t_bad_s - 1e-9 * self.dt)))
            self.live[k] = False
        self.plant.set_live(self.live)
