"""The runner: step loop, zero-order-hold control, decimated recording, divergence, checkpoints.

Each step ``k`` (time ``t = k·δt``):

1. if the controller is due (``t ≥ next sample``), it reads the state and returns a command,
   which is then held constant (zero-order hold) until its next sample;
2. ``xfrc_applied`` is zeroed and every load adds its wrench (vectorised, index arrays built
   once, see :mod:`magsail_mj.loads.base`);
3. every ``record_every`` steps the probes are sampled (before the step, so record 0 is the
   initial state);
4. ``mj_step`` integrates one step with the model's integrator (loads held over the step).

Load timing (:class:`LoadTiming`, ``sim.load_timing``): with ``"start"`` (the default) the loads
see the state at ``t``, so a load that depends on the state (a dipole torque m × B(q), tidal
gravity) is held at its start-of-step value and the run converges to first order in ``δt``
whatever the integrator. With ``"midpoint"`` they see a prediction of the state at ``t + δt/2``
(positions advanced by ``δt/2`` with the velocity extrapolated to ``t + δt/4``, velocities
extrapolated to ``t + δt/2`` from this and the previous step, the environment sampled at
``t + δt/2``): the held wrench is then the midpoint-rule value, and the run converges to second
order. Either way the loads add into ``xfrc_applied`` before ``mj_step`` (one door, no MuJoCo
callbacks). A load may declare ``at_step_start = True`` (stiff velocity feedback such as modal
damping, for which an extrapolated velocity could cost stability) to keep the start state.

After every step the state is checked (:mod:`magsail_mj.divergence`: MuJoCo's automatic reset
is off, its bad-state warnings and a finiteness check of ``qpos``/``qvel``): a bad state stops the
run with ``status = "diverged"`` and the simulated time of the first bad state, within one step.
A strut strain above ``max_strain`` (checked at record steps) stops it with ``status =
"structure_failed"``: the structure failed, the numbers up to then are valid. Either way
:class:`RunResult` keeps everything recorded up to that point.

A stop rule (``Simulation.stop_rule``, :class:`HoldBelow`) ends a run early with ``status =
"completed"``: checked after each record, it ends the run at the first record at which a recorded
vector's norm has stayed below a threshold for a hold time (a detumbled spacecraft: nothing more to
compute). The run's end time is that record's; everything up to it equals the run without the rule.

Records go to a :class:`~magsail_mj.records.Recorder`: a fixed buffer of one chunk per probe,
streamed to a Zarr store when :meth:`Simulation.run` is given ``records_path`` (a run folder's
``timeseries.zarr``; a checkpointed run without it streams to ``<checkpoint stem>.records.zarr``
beside the checkpoint), so record memory stays flat in run length; without a store (stepping
through the API, environments) the chunks stay in memory.

Checkpoints (every ``checkpoint_every_s`` simulated seconds) are data only
(:mod:`magsail_mj.checkpoint`, a NumPy ``.npz`` read without pickles): MuJoCo's integration
state, the held command, and every value of the controller, loads, environment and probes that
changed since the build, with the run's identity (hash of the number-changing config keys,
versions). A checkpoint carries no records: its header holds the record count and the store's
name, and the store is flushed when it is written, so a checkpoint costs the same at every time
of a long run. ``resume=True`` rebuilds nothing itself: the caller builds the same scenario, the
checkpoint's values are written into it and the store is cut to the checkpoint's record count;
a checkpoint of another config or build is refused
(:class:`~magsail_mj.checkpoint.CheckpointError`). The resumed run gives the same numbers as an
uninterrupted one.

Compiled loads (``Simulation.compiled``, ``sim.loads = "compiled"``): the loads are a MuJoCo plugin
of the model that MuJoCo calls inside ``mj_step`` (:mod:`magsail_mj.compiled`), so the runner adds
nothing to ``xfrc_applied`` and Python acts only at the controller's samples, the records, the
checkpoints and the run's end: the steps between run in one native ``mj_step(m, d, n)`` call. The
plugin's state (held commands, the step's memory) is part of MuJoCo's integration state, so
checkpoints and ``get_state`` carry it. A chunk after which MuJoCo warned or the state is not
finite is stepped again from its start one step at a time with the checks of the Python loop, so
a divergence is dated within one step as there.
"""

from __future__ import annotations

import abc
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Protocol, Sequence

import mujoco
import numpy as np
from tqdm import tqdm

from magsail_mj.checkpoint import (
    CheckpointError,
    StateWalker,
    check_identity,
    read_checkpoint,
    restore_state,
    run_identity,
    write_checkpoint,
)
from magsail_mj.divergence import (
    DivergenceError,
    StructureFailure,
    StudiedFailure,
    WarningWatch,
    disable_autoreset,
    route_mujoco_warnings,
)
from magsail_mj.loads.base import Load, StepState
from magsail_mj.records import Recorder, RecordStoreError

__all__ = [
    "Controller",
    "BodyKinematics",
    "LoadTiming",
    "Simulation",
    "RunResult",
    "DivergenceError",
    "StructureFailure",
    "LOAD_TIMINGS",
    "SteppedRun",
    "WholeRun",
    "progress_bar",
    "HoldBelow",
    "hold_below_time",
    "vector_norm",
]

#: when the loads see the state: at the step's start, predicted at its middle (see the module docs), or
#: at every stage of the integrator (loads computed inside MuJoCo's step only: ``Simulation.compiled``)
LOAD_TIMINGS = ("start", "midpoint", "stage")

_STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION


class Controller(Protocol):
    """A sampled controller: ``update`` runs every ``period_s`` and its output is held."""

    period_s: float

    def update(self, state: StepState) -> Any: ...


class BodyKinematics:
    """World pose and velocity of every body, read straight from ``qpos``/``qvel``.

    Particle bodies (three world-aligned slide joints) and free bodies are handled with index
    arrays built once; any other body (e.g. a wheel hinged to a bus) gets ``xpos``/``xquat``
    from ``mj_kinematics``, which is then run before the loads each step.
    """

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        nb = model.nbody
        self.pos0 = model.body_pos.copy()
        part_body, part_q, part_v = [], [], []
        free_body, free_q, free_v = [], [], []
        other = []
        for b in range(1, nb):
            jn, ja = model.body_jntnum[b], model.body_jntadr[b]
            types = model.jnt_type[ja : ja + jn] if jn else []
            if jn == 1 and types[0] == mujoco.mjtJoint.mjJNT_FREE:
                free_body.append(b)
                free_q.append(model.jnt_qposadr[ja])
                free_v.append(model.jnt_dofadr[ja])
            elif (
                jn == 3
                and np.all(types == mujoco.mjtJoint.mjJNT_SLIDE)
                and np.allclose(model.jnt_axis[ja : ja + 3], np.eye(3))
                and model.body_parentid[b] == 0
                and np.allclose(model.body_quat[b], [1, 0, 0, 0])
            ):
                part_body.append(b)
                part_q.append(model.jnt_qposadr[ja])
                part_v.append(model.jnt_dofadr[ja])
            elif jn == 0 and model.body_parentid[b] == 0:
                continue  # welded to the world: fixed pose, zero velocity
            else:
                other.append(b)
        self.part_body = np.array(part_body, dtype=int)
        self.part_q = np.array(part_q, dtype=int)[:, None] + np.arange(3) if part_q else np.zeros((0, 3), int)
        self.part_v = np.array(part_v, dtype=int)[:, None] + np.arange(3) if part_v else np.zeros((0, 3), int)
        self.free_body = np.array(free_body, dtype=int)
        self.free_q = np.array(free_q, dtype=int)
        self.free_v = np.array(free_v, dtype=int)
        self.other = np.array(other, dtype=int)
        # contiguous body ranges are read through slices (NumPy's fancy indexing costs µs per call)
        self._other = _slice_if_contiguous(self.other)
        self._free = [(int(b), int(q), int(v)) for b, q, v in zip(free_body, free_q, free_v)]
        self._R = np.zeros(9)
        # a lattice's particles are usually bodies 1 … n with qpos/qvel 0 … 3n − 1: plain views
        self._part_block = None
        if self.part_body.size:
            n, b0 = self.part_body.size, int(self.part_body[0])
            q0, v0 = int(self.part_q[0, 0]), int(self.part_v[0, 0])
            if (
                np.array_equal(self.part_body, np.arange(b0, b0 + n))
                and np.array_equal(self.part_q.ravel(), np.arange(q0, q0 + 3 * n))
                and np.array_equal(self.part_v.ravel(), np.arange(v0, v0 + 3 * n))
            ):
                self._part_block = (slice(b0, b0 + n), slice(q0, q0 + 3 * n), slice(v0, v0 + 3 * n), n)
        self.pos = np.zeros((nb, 3))
        self.pos[:] = model.body_pos
        self.vel = np.zeros((nb, 3))
        self.xquat = np.tile([1.0, 0, 0, 0], (nb, 1))
        self.xquat[:] = model.body_quat
        self.omega = np.zeros((nb, 3))

    def update(self, data: mujoco.MjData) -> None:
        """Refresh ``pos``, ``vel``, ``xquat``, ``omega`` from ``data.qpos``/``data.qvel``."""
        if self.other.size:
            mujoco.mj_kinematics(self.model, data)
            o = self._other
            self.pos[o] = data.xpos[o]
            self.xquat[o] = data.xquat[o]
        if self._part_block is not None:
            bs, qs, vs, n = self._part_block
            np.add(self.pos0[bs], data.qpos[qs].reshape(n, 3), out=self.pos[bs])
            self.vel[bs] = data.qvel[vs].reshape(n, 3)
        elif self.part_body.size:
            self.pos[self.part_body] = self.pos0[self.part_body] + data.qpos[self.part_q]
            self.vel[self.part_body] = data.qvel[self.part_v]
        R = self._R
        for b, qa, va in self._free:  # plain floats: a NumPy call on a 4-vector costs more than its arithmetic
            qp = data.qpos[qa : qa + 7].tolist()
            w, x, y, z = qp[3:]
            n = math.sqrt(w * w + x * x + y * y + z * z)
            q = self.xquat[b]
            q[:] = (w / n, x / n, y / n, z / n)
            self.pos[b] = qp[:3]
            qv = data.qvel[va : va + 6].tolist()
            self.vel[b] = qv[:3]
            mujoco.mju_quat2Mat(R, q)
            r = R.tolist()
            a0, a1, a2 = qv[3:]
            self.omega[b] = (
                r[0] * a0 + r[1] * a1 + r[2] * a2,
                r[3] * a0 + r[4] * a1 + r[5] * a2,
                r[6] * a0 + r[7] * a1 + r[8] * a2,
            )


def _slice_if_contiguous(index: np.ndarray) -> slice | np.ndarray:
    """``slice(i0, i0 + n)`` when ``index`` is ``i0, i0 + 1, …``, else ``index``."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + int(index.size))
    return index


def vector_norm(x: np.ndarray) -> np.ndarray:
    """‖x‖ over the last axis, ``sqrt(x₀² + x₁² + …)`` summed in index order (element-wise, so one
    vector and a stack of vectors round alike: a batch's worlds and their single runs agree bit
    for bit)."""
    x = np.asarray(x, dtype=float)
    total = x[..., 0] * x[..., 0]
    for i in range(1, x.shape[-1]):
        total = total + x[..., i] * x[..., i]
    return np.sqrt(total)


def hold_below_time(
    t: np.ndarray, x: np.ndarray, *, threshold: float, hold_s: float, tolerance_s: float = 0.0
) -> float | None:
    """The first record time at which ‖x‖ has stayed below ``threshold`` for ``hold_s`` [s]:
    the first ``t_k`` with ``‖x_j‖ < threshold`` for every record ``j`` from ``a`` to ``k`` and
    ``t_k − t_a ≥ hold_s − tolerance_s``, ``a`` the first record of that run of records below
    (``None`` when no record qualifies). ``t``: (n,) record times [s]; ``x``: (n, d) the recorded
    vectors (norms by :func:`vector_norm`). What :class:`HoldBelow` computes record by record."""
    t = np.asarray(t, dtype=float)
    below = vector_norm(x) < threshold
    if not below.any():
        return None
    idx = np.arange(t.size)
    start = np.maximum.accumulate(np.where(below, 0, idx + 1))  # first index of the current run below
    start = np.minimum(start, t.size - 1)
    held = below & (t - t[start] >= hold_s - tolerance_s)
    hits = np.flatnonzero(held)
    return float(t[hits[0]]) if hits.size else None


@dataclass
class HoldBelow:
    """A stop rule: end the run (status ``completed``) once ‖``probe``[``index``]‖ has stayed below
    ``threshold`` for ``hold_s``.

    Checked after every record: with ``s_k = ‖x_k‖`` (:func:`vector_norm`) of record ``k`` at time
    ``t_k`` and ``a`` the first record of the current run of records with ``s < threshold``, the run
    ends at the first record with ``t_k − t_a ≥ hold_s`` (within ``tolerance_s``, e.g. 10⁻⁶ δt: the
    record times are step·δt); ``hold_s = 0`` ends it at the first record below. On a run's records
    the same time is :func:`hold_below_time`.

    Attributes:
      probe: the recorded variable (e.g. ``"qvel"``); index: the components of it (a slice).
      threshold: in the probe's unit; hold_s: [s]; tolerance_s: [s].
      describe: what the rule is, for the run's message (e.g. ``"|ω| < 0.3 °/s (sim.stop_rate_deg_s)
        for 600 s (sim.stop_hold_s)"``).
      below_since_s: ``t_a`` of the current run of records below (``None``: the last record was not
        below); the rule's state, part of the run's checkpoints.
    """

    probe: str
    index: slice
    threshold: float
    hold_s: float
    tolerance_s: float
    describe: str
    below_since_s: float | None = None

    def check(self, t: float, values: Mapping[str, Any]) -> str | None:
        """The record at ``t`` [s] with the probes' ``values``: the run's end message when the rule
        ends the run here, else ``None``."""
        s = float(vector_norm(np.asarray(values[self.probe])[self.index]))
        if not s < self.threshold:
            self.below_since_s = None
            return None
        if self.below_since_s is None:
            self.below_since_s = t
        if t - self.below_since_s >= self.hold_s - self.tolerance_s:
            return f"{self.describe}: held from t = {self.below_since_s:.6g} s; the run ended at t = {t:.6g} s"
        return None


@dataclass
class RunResult:
    """What a run produced.

    ``records`` maps probe names to arrays stacked over record times (first axis), with ``t``
    (a dict in memory, or a read-only :class:`~magsail_mj.records.StoreRecords` reading each
    variable from the run's store on first access).
    ``status`` is ``"completed"``, ``"diverged"``, ``"structure_failed"``, ``"stopped"``
    (``stop_after_s`` reached) or ``"interrupted"`` (Ctrl-C: the records up to then are kept).
    ``steps`` counts every step from t = 0 to ``t_end_s`` and ``wall_time_s`` [s] the wall time of
    their step loops, a resumed run's earlier calls included (both carried by the checkpoint), so
    ``wall_time_s / steps`` is the cost of a step.
    """

    records: Mapping[str, np.ndarray]
    status: str
    message: str
    t_end_s: float
    steps: int
    wall_time_s: float


class SteppedRun:
    """What :class:`Simulation` and the chunked runners of the concepts share: :meth:`step` in terms of
    the subclass's ``_advance(stop_step, ...)``, the progress bar and the :class:`RunResult` of ``run``,
    and the writing and reading of checkpoints.

    A subclass holds ``status``, ``message``, ``step_index``, ``n_steps``, ``time`` [s], ``_wall_s``
    [s], ``identity``, ``recorder``, ``records()`` and ``get_state()``, and defines
    ``_advance(stop_step, *, bar, ...)``.
    """

    def step(self, n: int = 1) -> str:
        """Advance ``n`` physics steps (controller samples, records and loads as in ``run``; never
        beyond ``duration_s``) and return the status: ``running`` while steps remain, else how the
        run ended."""
        if int(n) != n or n < 1:
            raise ValueError(f"n: must be an integer >= 1, got {n!r}")
        if self.status == "running":
            self._advance(min(self.step_index + int(n), self.n_steps))
        return self.status

    def _advance_with_bar(self, stop_step: int, bar: Any, **options: Any) -> None:
        """``_advance(stop_step, bar=bar, **options)`` while the run is running; ``bar`` (a tqdm bar
        or ``None``) is closed afterwards whatever happens."""
        try:
            if self.status == "running":
                self._advance(stop_step, bar=bar, **options)
        finally:
            if bar is not None:
                bar.close()

    def _write_checkpoint(self, path: Path, *, mj_state_key: str, **header: Any) -> None:
        """Write the current state to the checkpoint ``path``: a header of the run's identity, step,
        time [s], wall time [s], record count, record store name and ``header``, the Python-side
        state, and MuJoCo's state under ``mj_state_key``. The record store is flushed first, so it
        holds every record the checkpoint counts."""
        self.recorder.flush()
        state = self.get_state()
        store = self.recorder.path
        head = {
            **self.identity,
            "step": state["step"],
            "t_s": self.time,
            "wall_s": self._wall_s,
            "n_records": state["n_records"],
            "records_store": store.name if store is not None else None,
            "records_digests": self.recorder.digest_table() if store is not None else None,
            **header,
        }
        write_checkpoint(
            path,
            head,
            tree=state["python_tree"],
            arrays=state["python_arrays"],
            extra_arrays={mj_state_key: state["mj_state"]},
        )

    def _read_checkpoint(self, path: Path) -> tuple[dict[str, Any], dict[str, np.ndarray], dict[str, np.ndarray]]:
        """``(header, arrays, extra arrays)`` of the checkpoint ``path``, refused
        (:class:`~magsail_mj.checkpoint.CheckpointError`) unless it is a checkpoint of this run's identity."""
        header, arrays, extra = read_checkpoint(path)
        check_identity(header, self.identity, path=path)
        return header, arrays, extra

    def _reopen_store(self, path: Path, store: Path, header: dict[str, Any]) -> None:
        """Continue the record store ``store`` cut to the ``n_records`` the checkpoint ``path``
        (its ``header``) counts, after reading it back against the checkpoint's digests of every
        chunk; a store that cannot be continued, or whose records differ from the digests (a
        deleted, truncated or edited chunk), is a :class:`~magsail_mj.checkpoint.CheckpointError`."""
        digests = header.get("records_digests")
        if not isinstance(digests, dict):
            raise CheckpointError(
                f"checkpoint: {path} carries no digests of its records (a checkpoint of an older version)"
            )
        try:
            self.recorder.open_store(store, int(header["n_records"]), digests=digests)
        except RecordStoreError as err:
            raise CheckpointError(f"checkpoint: {path}: {err}") from None

    def _result(self) -> RunResult:
        """The :class:`RunResult` of the run so far: every step from t = 0 (a resumed run's steps
        before its checkpoint included) and the wall time of their step loops, which the checkpoint
        carries over."""
        return RunResult(
            records=self.records(),
            status=self.status,
            message=self.message,
            t_end_s=self.time,
            steps=self.step_index,
            wall_time_s=self._wall_s,
        )


class WholeRun(abc.ABC):
    """A runner whose ``run`` does all its work in one call (an analysis, a sweep of whole runs): no
    step loop, so no checkpoints to stop at or resume from (``checkpoints = False``; the run folder
    refuses ``resume`` and ``stop_after_s`` for it)."""

    checkpoints = False

    def run(
        self,
        *,
        progress: bool = False,
        checkpoint_path: Any = None,
        resume: bool = False,
        stop_after_s: float | None = None,
    ) -> RunResult:
        """:meth:`run_whole`; the checkpoint options of :meth:`Simulation.run` are accepted for the
        common interface and have nothing to act on."""
        return self.run_whole(progress=progress)

    @abc.abstractmethod
    def run_whole(self, *, progress: bool) -> RunResult:
        """The whole run (``progress``: show progress on stderr where the runner can)."""


def progress_bar(*, total: int, initial: int, mininterval_s: float, unit_scale: bool = False) -> Any:
    """A tqdm bar of ``total`` steps on stderr starting at ``initial``, refreshed at most every
    ``mininterval_s`` [s] of wall time and removed when closed."""
    return tqdm(
        total=total,
        initial=initial,
        unit="step",
        unit_scale=unit_scale,
        file=sys.stderr,
        mininterval=mininterval_s,
        leave=False,
    )


@dataclass
class LoadTiming:
    """When the loads see the state (``mode``: one of :data:`LOAD_TIMINGS`), and the velocity of the
    previous step that the midpoint prediction extrapolates from (part of the run's state: it is
    checkpointed, and ``primed`` is False until a step has been taken).

    Attributes:
      mode: ``"start"`` or ``"midpoint"``.
      qvel_prev: (nv,) ``qvel`` at the start of the previous step.
      primed: whether ``qvel_prev`` holds a step (the first prediction uses ``qvel`` alone).
    """

    mode: str
    qvel_prev: np.ndarray
    primed: bool = False

    def __post_init__(self) -> None:
        if self.mode not in LOAD_TIMINGS:
            raise ValueError(f"load_timing: must be one of {LOAD_TIMINGS}, got {self.mode!r}")

    def predict(self, m: mujoco.MjModel, d: mujoco.MjData, scratch: mujoco.MjData, dt: float) -> None:
        """Write the predicted state at ``t + δt/2`` into ``scratch.qpos``/``scratch.qvel`` and keep
        this step's ``qvel`` for the next prediction.

        ``q(t + δt/2) = q ⊕ (δt/2)·v(t + δt/4)`` (``mj_integratePos``: quaternions on the sphere),
        ``v(t + δt/4) ≈ v + (v − v_prev)/4`` and ``v(t + δt/2) ≈ v + (v − v_prev)/2``: errors
        O(δt²) in the state, so the held wrench is the midpoint value to O(δt²) and a step's error
        is O(δt³)."""
        v = d.qvel
        dv = (v - self.qvel_prev) if self.primed else np.zeros_like(v)
        scratch.qpos[:] = d.qpos
        mujoco.mj_integratePos(m, scratch.qpos, v + 0.25 * dv, 0.5 * dt)
        np.add(v, 0.5 * dv, out=scratch.qvel)
        self.qvel_prev[:] = v
        self.primed = True


@dataclass
class Simulation(SteppedRun):
    """A model with its loads, controller, environment and probes, ready to run.

    Attributes:
      model: compiled MuJoCo model (``opt.timestep`` and ``opt.integrator`` are used as set).
      duration_s: simulated time to run.
      loads: force models adding into ``xfrc_applied`` each step.
      controller: sampled controller, or ``None``; its command is passed to loads as
        ``state.ctrl``, and a command with an ``apply_ctrl(data)`` method may also set ``data.ctrl``.
      environment: object with ``sample(t)`` (see :mod:`magsail_mj.environment`), or ``None``.
      probes: name → function(state, data) returning an array recorded every ``record_every`` steps.
      record_every: decimation of the recorder.
      strain_check: function(positions) → (max strain, strut index), checked at record steps.
      max_strain: divergence bound on strut strain.
      checkpoint_every_s: checkpoint interval in simulated seconds (0 = none).
      init: function(data) setting the initial state (qpos, qvel, time) before the run.
      load_timing: ``"start"`` or ``"midpoint"`` (see the module docs; ``sim.load_timing``).
      identity: what a checkpoint of this run must match (:func:`~magsail_mj.checkpoint.run_identity`;
        the runner of a config sets the config's hash).
      compiled: the loads MuJoCo computes inside ``mj_step`` (a compiled plugin of ``model``, e.g.
        :class:`magsail_mj.concepts.cnusail.compiled.CompiledCubesat`; it has ``bare_model``, the
        same model without the plugin), or ``None``; with it ``loads`` must be empty and the steps
        between samples, records and checkpoints run natively (module docs).
      stop_rule: a :class:`HoldBelow` checked after every record (it ends the run, ``completed``,
        once its condition holds), or ``None``.

    :meth:`~SteppedRun.step` (advance ``n`` steps) comes from :class:`SteppedRun`.
    """

    #: records stream to a store given to :meth:`run` (``records_path``)
    streams_records = True

    model: mujoco.MjModel
    duration_s: float
    loads: Sequence[Load] = ()
    controller: Controller | None = None
    environment: Any = None
    probes: dict[str, Callable[[StepState, mujoco.MjData], Any]] = field(default_factory=dict)
    record_every: int = 10
    strain_check: Callable[[np.ndarray], tuple[float, int]] | None = None
    max_strain: float = 0.5
    checkpoint_every_s: float = 0.0
    init: Callable[[mujoco.MjData], None] | None = None
    load_timing: str = "start"
    identity: dict[str, Any] = field(default_factory=lambda: run_identity(None))
    compiled: Any = None
    stop_rule: HoldBelow | None = None

    def __post_init__(self) -> None:
        if self.record_every < 1:
            raise ValueError(f"record_every: must be >= 1, got {self.record_every}")
        if self.compiled is not None and len(self.loads):
            raise ValueError(
                f"loads: with compiled loads MuJoCo computes every load inside the step; got {len(self.loads)} "
                "Python loads as well"
            )
        route_mujoco_warnings()
        disable_autoreset(self.model)
        self.data = mujoco.MjData(self.model)
        if self.init is not None:
            self.init(self.data)
        self.kin = BodyKinematics(self.model)
        self.timing = LoadTiming(self.load_timing, np.zeros(self.model.nv))
        self._mid_data = mujoco.MjData(self.model)  # the predicted mid-step state (scratch)
        self._mid_kin = BodyKinematics(self.model)
        self.n_steps = int(round(self.duration_s / self.model.opt.timestep))
        self.walker = self._state_walker()
        self.walker.baseline()
        self.recorder = Recorder(["t", *self.probes])
        self._begin(0, self._new_loop())
        self._initial = self.get_state()

    # ------------------------------------------------------------------ state
    def _new_loop(self) -> dict[str, Any]:
        return {"cmd": None, "n_ctrl": 0}

    def _begin(self, step: int, loop: dict[str, Any]) -> None:
        """Make ``step`` the current step with the bookkeeping ``loop`` (records, held command)."""
        self._loop = loop
        self.step_index = step
        self.status, self.message = "running", ""
        self._wall_s = float(loop.get("wall_s", 0.0))
        self._watch = WarningWatch(self.data)

    @property
    def time(self) -> float:
        """Simulated time of the current state [s] (``step_index · δt``)."""
        return self.step_index * self.model.opt.timestep

    def records(self) -> Mapping[str, np.ndarray]:
        """The records so far (``t`` and every probe), stacked over record times (from the store
        when the run streams to one, read lazily)."""
        return self.recorder.arrays()

    def get_state(self) -> dict[str, Any]:
        """The whole state as plain data: MuJoCo's integration state, the step, the controller's
        sample count, the record count, and the snapshot of the Python-side state (a JSON-able
        ``python_tree`` and its ``python_arrays``; see :mod:`magsail_mj.checkpoint`)."""
        mj_state = np.empty(mujoco.mj_stateSize(self.model, _STATE_SPEC))
        mujoco.mj_getState(self.model, self.data, mj_state, _STATE_SPEC)
        self.walker.roots["cmd"] = self._loop["cmd"]
        tree, arrays = self.walker.snapshot()
        n_records = len(self.recorder)
        return {
            "step": self.step_index,
            "n_ctrl": self._loop["n_ctrl"],
            "mj_state": mj_state,
            "n_records": n_records,
            "python_tree": tree,
            "python_arrays": arrays,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state` (of this simulation or one built from the same
        config): the following steps equal those that followed the state's own. Records made after
        the state are dropped (from the store too); the status is ``running`` again. The load timing
        is configuration (``load_timing``) and stays as configured."""
        mj_state = np.asarray(state["mj_state"], dtype=float)
        if mj_state.shape != (mujoco.mj_stateSize(self.model, _STATE_SPEC),):
            raise ValueError(f"state: 'mj_state' has shape {mj_state.shape}, not this model's")
        step = int(state["step"])
        if not 0 <= step <= self.n_steps:
            raise ValueError(f"state: step {step} is outside 0 … {self.n_steps}")
        restore_state(self.walker, state["python_tree"], state["python_arrays"])
        # the load timing is configuration, not state: a state taken before it was configured (the
        # initial state of reset(), taken at build, before magsail_mj.load sets sim.load_timing)
        # must not put back the timing of the build
        self.timing.mode = self.load_timing
        self.controller = self.walker.roots["controller"]
        mujoco.mj_setState(self.model, self.data, mj_state, _STATE_SPEC)
        loop = self._loop
        loop["cmd"], loop["n_ctrl"] = self.walker.roots["cmd"], int(state["n_ctrl"])
        keep = int(state.get("n_records", len(self.recorder)))
        self.recorder.truncate(min(keep, len(self.recorder)))
        self.step_index = step
        self.status, self.message = "running", ""
        self._watch = WarningWatch(self.data)

    def reset(self, *, seed: int | None = None) -> None:
        """Back to the initial state of the build (t = 0, no records).

        The random generators of the run (sensor noise, disturbance sampling: every
        ``numpy.random.Generator`` or ``RandomState`` held by the controller, the loads, the
        environment and the probes) go back to their initial state too, so a reset run repeats
        its first run exactly. ``seed`` reseeds them instead: each from its own child of
        ``numpy.random.SeedSequence(seed)``, in a fixed order, so equal seeds give equal runs and
        different seeds different noise. A run without random generators is deterministic and
        ``seed`` changes nothing in it (the seed reseeds only the generators present).
        """
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ValueError(f"seed: must be an integer >= 0 or None, got {seed!r}")
        self.set_state(self._initial)
        self.recorder.truncate(0)
        self._begin(0, self._new_loop())
        if seed is None:
            return

        def collect(obj: Any, seen: set[int], found: list[Any]) -> list[Any]:
            """Append the random generators reachable from ``obj`` (through containers and
            magsail_mj objects, each object once) to ``found``; return it."""
            if id(obj) in seen:
                return found
            seen.add(id(obj))
            if isinstance(obj, (np.random.Generator, np.random.RandomState)):
                found.append(obj)
            elif isinstance(obj, Mapping):
                for value in obj.values():
                    collect(value, seen, found)
            elif isinstance(obj, (list, tuple)):
                for value in obj:
                    collect(value, seen, found)
            elif type(obj).__module__.startswith("magsail_mj") and hasattr(obj, "__dict__"):
                for value in vars(obj).values():
                    collect(value, seen, found)
            return found

        roots = (self.controller, list(self.loads), self.environment, dict(self.probes))
        found = collect(roots, set(), [])
        for rng, child in zip(found, np.random.SeedSequence(int(seed)).spawn(len(found))):
            if isinstance(rng, np.random.Generator):
                rng.bit_generator.state = np.random.default_rng(child).bit_generator.state
            else:
                rng.seed(child.generate_state(1)[0])

    # ------------------------------------------------------------------ checkpoints
    def _state_walker(self) -> StateWalker:
        """The Python-side state of the run: controller, loads, environment and probes."""
        roots = {
            "controller": self.controller,
            "loads": list(self.loads),
            "environment": self.environment,
            "probes": dict(self.probes),
            "cmd": None,
            "timing": self.timing,
        }
        if self.stop_rule is not None:  # only then: the checkpoints of runs without one keep their form
            roots["stop_rule"] = self.stop_rule
        return StateWalker(roots)

    def _checkpoint(self, path: Path) -> None:
        self._write_checkpoint(path, mj_state_key="mj_state", n_ctrl=self._loop["n_ctrl"])

    def _restore(self, path: Path, records_path: Path | None) -> None:
        header, arrays, extra = self._read_checkpoint(path)
        if "mj_state" not in extra or extra["mj_state"].shape != (mujoco.mj_stateSize(self.model, _STATE_SPEC),):
            raise CheckpointError(f"checkpoint: {path} holds no MuJoCo state of this model")
        step = int(header["step"])
        if step > self.n_steps:
            raise CheckpointError(
                f"checkpoint: {path} is at t = {header['t_s']:g} s, beyond sim.duration_s = "
                f"{self.duration_s:g} s (a resume may extend a run, not shorten it)"
            )
        if "n_records" not in header:
            raise CheckpointError(f"checkpoint: {path} holds no record count (a checkpoint of an older version)")
        n_records = int(header["n_records"])
        if records_path is None:
            raise CheckpointError(f"checkpoint: {path} needs its record store (records_path)")
        self._reopen_store(path, records_path, header)
        loop = self._new_loop()
        loop.update(wall_s=float(header["wall_s"]))
        self._loop = loop
        self.set_state(
            {
                "step": step,
                "n_ctrl": int(header["n_ctrl"]),
                "mj_state": extra["mj_state"],
                "n_records": n_records,
                "python_tree": header["state_tree"],
                "python_arrays": arrays,
            }
        )
        self._wall_s = loop["wall_s"]

    # ------------------------------------------------------------------ stepping
    def run(
        self,
        *,
        progress: bool = False,
        checkpoint_path: str | Path | None = None,
        resume: bool = False,
        stop_after_s: float | None = None,
        records_path: str | Path | None = None,
        records_attrs: dict[str, Any] | None = None,
    ) -> RunResult:
        """Run from the current state to ``duration_s`` (or until divergence, structural failure,
        interrupt or ``stop_after_s``), checkpointing every ``checkpoint_every_s``.

        Records stream to the Zarr store ``records_path`` (created, or continued on ``resume``),
        with ``records_attrs`` as its attributes; a checkpointed run without it streams to
        ``<checkpoint stem>.records.zarr`` beside the checkpoint."""
        dt = self.model.opt.timestep
        ckpt = open_run_records(
            self.recorder,
            checkpoint_path=checkpoint_path,
            records_path=records_path,
            records_attrs=records_attrs,
            restore=self._restore if resume else None,
        )
        start = self.step_index
        ckpt_every = int(round(self.checkpoint_every_s / dt)) if self.checkpoint_every_s > 0 else 0
        stop_step = self.n_steps if stop_after_s is None else min(self.n_steps, int(round(stop_after_s / dt)))
        bar = None
        if progress and self.n_steps > 2000:
            bar = progress_bar(total=self.n_steps, initial=start, mininterval_s=1.0)
        self._advance_with_bar(stop_step, bar, ckpt=ckpt, ckpt_every=ckpt_every)
        if self.status == "running":  # stop_after_s reached before the end
            self.status, self.message = "stopped", f"stopped at t = {self.time:.6g} s (stop_after_s)"
        if self.status == "completed":
            self.status, self.message = _non_finite_records(self.recorder) or (self.status, self.message)
        return self._result()

    def _control_sample(self, state: StepState, t: float) -> None:
        """The controller's sample at ``t``: its command, held from now (``state.ctrl`` too), the
        index of the next sample and the command's actuator controls."""
        loop, dt = self._loop, self.model.opt.timestep
        loop["cmd"] = self.controller.update(state)
        state.ctrl = loop["cmd"]
        period = self.controller.period_s
        loop["n_ctrl"] = int(np.floor(t / period + 1e-6 * dt / period)) + 1
        if hasattr(loop["cmd"], "apply_ctrl"):
            loop["cmd"].apply_ctrl(self.data)

    def _record(self, state: StepState, t: float, pos: np.ndarray) -> str | None:
        """Record the probes at ``t``; then the strain check (StructureFailure: the failing state
        is valid and recorded first) and the stop rule, whose reason is returned when it ends the
        run (else None)."""
        values = {name: probe(state, self.data) for name, probe in self.probes.items()}
        values["t"] = t
        self.recorder.append(values)
        if self.strain_check is not None:
            strain, strut = self.strain_check(pos)
            if not strain <= self.max_strain:
                raise StructureFailure(
                    f"strut {strut} strain {strain:.3g} exceeds sim.max_strain {self.max_strain:g} at t = {t:.6g} s"
                )
        return self.stop_rule.check(t, values) if self.stop_rule is not None else None

    def _checkpoint_if_due(self, ckpt: Path, step: int, *, stop_step: int, every: int, wall0: float) -> float:
        """Write the checkpoint at ``step`` when it is due (every ``every`` steps, and at a stop
        before the end); returns the wall-clock origin of the loop's next interval."""
        if not ((every and step % every == 0) or step == stop_step < self.n_steps):
            return wall0
        now = time.perf_counter()
        self._wall_s += now - wall0
        self._loop["wall_s"] = self._wall_s
        self.step_index = step
        self._checkpoint(ckpt)  # its writing counts in the next interval, as the steps do
        return now

    def _advance(self, stop_step: int, *, ckpt: Path | None = None, ckpt_every: int = 0, bar: Any = None) -> None:
        """The step loop from the current step to ``stop_step`` (see the module docs)."""
        if self.compiled is not None:
            self._advance_native(stop_step, ckpt=ckpt, ckpt_every=ckpt_every, bar=bar)
            return
        if self.timing.mode == "stage":
            raise ValueError(
                "load_timing: 'stage' needs loads computed inside MuJoCo's step (compiled loads); "
                f"this simulation has {len(self.loads)} Python loads"
            )
        m, d = self.model, self.data
        dt = m.opt.timestep
        loop = self._loop
        recorder = self.recorder
        kin, watch = self.kin, self._watch
        midpoint = self.timing.mode == "midpoint"
        load_starts = [(load, bool(getattr(load, "at_step_start", False))) for load in self.loads]
        start_loads = any(at_start for _, at_start in load_starts)
        qpos, qvel = d.qpos, d.qvel
        small = m.nq + m.nv <= 64  # summing a short state as Python floats is 3x cheaper than two reductions
        start = step = self.step_index
        wall0 = time.perf_counter()
        try:
            watch.check(step * dt)
            for step in range(start, stop_step + 1):
                t = step * dt
                if ckpt is not None and step > start:
                    wall0 = self._checkpoint_if_due(ckpt, step, stop_step=stop_step, every=ckpt_every, wall0=wall0)
                if step == stop_step < self.n_steps:
                    break
                # sample k is due at k·period (computed, not accumulated, so no sample is ever
                # skipped by round-off); the step is due when t has reached it within 1e-6 δt
                due = self.controller is not None and t >= loop["n_ctrl"] * self.controller.period_s - 1e-6 * dt
                recording = step % self.record_every == 0 or step == self.n_steps
                # the start state is read when something uses it (with mid-step loads, only
                # the controller, the probes, the strain check and start-of-step loads do)
                at_t = not midpoint or due or recording or start_loads
                if at_t:
                    kin.update(d)
                env_t = self.environment.sample(t) if self.environment is not None and at_t else None
                state = StepState(
                    t=t, pos=kin.pos, vel=kin.vel, xquat=kin.xquat, omega=kin.omega, env=env_t, ctrl=loop["cmd"]
                )
                if due:
                    self._control_sample(state, t)
                if recording and (why := self._record(state, t, kin.pos)) is not None:
                    self.status, self.message = "completed", why
                    break
                if step == self.n_steps:
                    self.status = "completed"
                    break
                d.xfrc_applied[:] = 0.0
                if midpoint:
                    mid = self._mid_state(t, state)
                    for load, at_start in load_starts:
                        load.add(state if at_start else mid, d.xfrc_applied)
                else:
                    for load in self.loads:
                        load.add(state, d.xfrc_applied)
                mujoco.mj_step(m, d)
                # every step: MuJoCo checks the state it steps from (|q|, |v| > 1e10 or not
                # finite, bad qacc/ctrl), so a warning of this step dates the bad state at t;
                # a NaN/Inf in the new state makes the sum non-finite, dated t + δt
                watch.check(t)
                if not math.isfinite(
                    sum(qpos.tolist()) + sum(qvel.tolist()) if small else float(qpos.sum()) + float(qvel.sum())
                ):
                    raise DivergenceError(
                        f"state is not finite at t = {t + dt:.6g} s (after the step from t = {t:.6g} s)"
                    )
                if bar is not None and (step + 1) % 100 == 0:
                    bar.update(100)
            else:
                step = stop_step
        except DivergenceError as err:
            self.status, self.message = "diverged", str(err)
            if err.t_s is not None:  # a record of the bad state itself is not a valid number
                recorder.truncate(int(np.searchsorted(recorder.column("t"), err.t_s - 1e-9 * dt)))
        except StudiedFailure as err:
            self.status, self.message = err.status, str(err)
        except KeyboardInterrupt:
            self.status, self.message = "interrupted", f"interrupted at t = {step * dt:.6g} s"
            # a record interrupted half-way never counted (Recorder.append)
        finally:
            self.step_index = step
            self._wall_s += time.perf_counter() - wall0

    def _next_sample_step(self, step: int) -> int:
        """The first step after ``step`` at which the controller is due (the test of the Python loop:
        ``t ≥ n_ctrl · period − 10⁻⁶ δt``), or ``n_steps`` without a controller."""
        if self.controller is None:
            return self.n_steps
        dt = self.model.opt.timestep
        threshold = self._loop["n_ctrl"] * self.controller.period_s - 1e-6 * dt
        k = max(step + 1, math.ceil(threshold / dt))
        while k > step + 1 and (k - 1) * dt >= threshold:
            k -= 1
        while k * dt < threshold:
            k += 1
        return k

    def _advance_native(self, stop_step: int, *, ckpt: Path | None, ckpt_every: int, bar: Any) -> None:
        """The step loop with compiled loads (module docs): at each step where Python acts the
        controller, the probes and the checkpoint run as in :meth:`_advance`; the steps to the next
        such step run in one ``mj_step(m, d, n)`` call."""
        m, d = self.model, self.data
        dt = m.opt.timestep
        loop, recorder, kin = self._loop, self.recorder, self.kin
        qpos, qvel = d.qpos, d.qvel
        every = self.record_every
        snapshot = np.empty(mujoco.mj_stateSize(m, _STATE_SPEC))
        start = step = self.step_index
        pending = 0  # steps not yet shown on the progress bar
        replaying = False
        wall0 = time.perf_counter()
        try:
            self._watch.check(step * dt)
            while True:
                t = step * dt
                if ckpt is not None and step > start:
                    wall0 = self._checkpoint_if_due(ckpt, step, stop_step=stop_step, every=ckpt_every, wall0=wall0)
                if step == stop_step < self.n_steps:
                    break
                due = self.controller is not None and t >= loop["n_ctrl"] * self.controller.period_s - 1e-6 * dt
                recording = step % every == 0 or step == self.n_steps
                if due or recording:
                    kin.update(d)
                    env_t = self.environment.sample(t) if self.environment is not None else None
                    state = StepState(
                        t=t, pos=kin.pos, vel=kin.vel, xquat=kin.xquat, omega=kin.omega, env=env_t, ctrl=loop["cmd"]
                    )
                    if due:
                        self._control_sample(state, t)
                    if recording and (why := self._record(state, t, kin.pos)) is not None:
                        self.status, self.message = "completed", why
                        break
                if step == self.n_steps:
                    self.status = "completed"
                    break
                nxt = min(stop_step, self.n_steps, (step // every + 1) * every, self._next_sample_step(step))
                if ckpt is not None and ckpt_every:
                    nxt = min(nxt, (step // ckpt_every + 1) * ckpt_every)
                mujoco.mj_getState(m, d, snapshot, _STATE_SPEC)
                mujoco.mj_step(m, d, nxt - step)
                if self._watch.raised() or not math.isfinite(float(qpos.sum()) + float(qvel.sum())):
                    replaying = True
                    self._replay(snapshot, step, nxt)
                pending += nxt - step
                step = nxt
                if bar is not None and pending >= 100:
                    bar.update(pending)
                    pending = 0
        except DivergenceError as err:
            self.status, self.message = "diverged", str(err)
            if replaying:  # the replay dated the bad step
                step = self.step_index
            if err.t_s is not None:
                recorder.truncate(int(np.searchsorted(recorder.column("t"), err.t_s - 1e-9 * dt)))
        except StudiedFailure as err:
            self.status, self.message = err.status, str(err)
        except KeyboardInterrupt:
            self.status, self.message = "interrupted", f"interrupted at t = {step * dt:.6g} s"
        finally:
            self.step_index = step
            self._wall_s += time.perf_counter() - wall0

    def _replay(self, snapshot: np.ndarray, first: int, last: int) -> None:
        """Step again one step at a time from ``snapshot`` (the state of step ``first``) towards
        ``last`` with the Python loop's checks, raising :class:`DivergenceError` at the first bad
        step (MuJoCo's run is deterministic, so the chunk's failure recurs there)."""
        m, d = self.model, self.data
        dt = m.opt.timestep
        mujoco.mj_setState(m, d, snapshot, _STATE_SPEC)
        watch = WarningWatch(d)
        for step in range(first, last):
            self.step_index = step
            mujoco.mj_step(m, d)
            watch.check(step * dt)
            if not math.isfinite(float(d.qpos.sum()) + float(d.qvel.sum())):
                raise DivergenceError(
                    f"state is not finite at t = {(step + 1) * dt:.6g} s (after the step from t = {step * dt:.6g} s)"
                )
        raise DivergenceError(
            f"MuJoCo flagged the steps from t = {first * dt:.6g} s to {last * dt:.6g} s, "
            "which did not go bad again when repeated one by one",
            first * dt,
        )

    def _mid_state(self, t: float, state: StepState) -> StepState:
        """What the loads see with ``load_timing = "midpoint"``: the state predicted at ``t + δt/2``
        (:meth:`LoadTiming.predict`), its body kinematics and the environment then."""
        dt = self.model.opt.timestep
        self.timing.predict(self.model, self.data, self._mid_data, dt)
        k = self._mid_kin
        k.update(self._mid_data)
        env = self.environment.sample(t + 0.5 * dt) if self.environment is not None else None
        return StepState(t=t + 0.5 * dt, pos=k.pos, vel=k.vel, xquat=k.xquat, omega=k.omega, env=env, ctrl=state.ctrl)


def open_run_records(
    recorder: Recorder,
    *,
    checkpoint_path: str | Path | None,
    records_path: str | Path | None,
    records_attrs: dict[str, Any] | None,
    restore: Callable[[Path, Path | None], None] | None,
) -> Path | None:
    """Start a run's records: return the checkpoint path (or ``None``).

    The store is ``records_path``, else ``<checkpoint stem>.records.zarr`` beside a checkpoint, else
    none (records stay in memory). With ``restore`` (a resume), ``restore(checkpoint, store)``
    continues the checkpointed run and its store; otherwise a new store is created with
    ``records_attrs`` unless the recorder already writes to it.

    Raises:
      CheckpointError: a resume without a checkpoint path.
    """
    ckpt = Path(checkpoint_path) if checkpoint_path else None
    store = (
        Path(records_path)
        if records_path
        else (ckpt.with_name(f"{ckpt.stem}.records.zarr") if ckpt is not None else None)
    )
    if restore is not None:
        if ckpt is None:
            raise CheckpointError("resume: no checkpoint path given")
        restore(ckpt, store)
    elif store is not None and recorder.path != store:
        recorder.create_store(store, attrs=records_attrs)
    return ckpt


def _non_finite_records(recorder: Recorder) -> tuple[str, str] | None:
    """``("failed", why)`` when a recorded series holds a value that is not finite (a probe that
    overflowed although the state stayed finite, e.g. an input near the float64 limit), else None.
    The recorder checks each chunk as it is completed, so nothing is read back."""
    bad = recorder.non_finite()
    if bad is None:
        return None
    name, t = bad
    return "failed", (
        f"the recorded series {name!r} is not finite from t = {t:.6g} s although the state stayed "
        "finite (an input too large for float64?)"
    )
