r"""Native-speed runner of the MSAC multibody model.

The paper case is 1.2·10⁸ RK4 steps (600 s at 5 µs), so no Python function may run per step.
:class:`MsacRunner` with ``method="replay"`` records one settled cycle of computed torques
(:func:`magsail_mj.concepts.msac.drive.replay_table`, a few hundred Python steps), then drives
MuJoCo through :func:`mujoco.rollout.rollout` in chunks of whole cycles with a precomputed,
periodic control array (feed-forward torques + servo set-points). ``method="computed_torque"``
runs the per-step Python computed-torque loop instead (for verification and short runs); both
produce identical record layouts.

Per step ``k`` the runner sees the step-start state ``x_k`` (time ``t_k = k δt``), the
controls ``u_k`` and the sensors (evaluated by MuJoCo at ``x_k``). From each chunk it keeps,
vectorised:

* ``records`` every ``record_every`` steps: ``t``, ``qpos``, ``qvel``, ``omega_world_rad_s``
  (bus angular velocity in world axes), ``angmom_Nms`` (total angular momentum, world axes,
  about the system centre of mass), ``joint_force`` (actuator torque/force on the four shape
  joints, N m / N), ``phase`` (1..4);
* the stroboscopic series at every cycle start: ``strobe_t``, ``strobe_quat`` (bus
  quaternion), ``strobe_shape`` (the four shape joint positions);
* full-rate windows (``win_*``) of ``window_s`` at the start, the middle and the end;
* world ``ω_z`` block-averaged to ``omega_sample_hz`` (≥ 20 kHz), low-pass filtered at the
  end of the run (zero-phase Butterworth) and kept decimated to 1 kHz
  (``omega_filt_t``, ``omega_z_filtered_rad_s``), plus its per-cycle extremes
  (``omega_z_cycle_min_rad_s``/``_max_``) for the raw-signal envelope of a long run;
* running maxima (``run_*``): angular-momentum drift ``max|L − L_0|``, peak hinge torque and
  slide force, shape tracking error ``max|q − q_des|``; and the momentum removed by the
  projection at chunk boundaries (``run_momentum_projection_*``, see :meth:`MsacRunner._project`).

Angular momentum. The exact dynamics conserve the total momentum (every drive force is an
internal joint force). The computed-torque loop and ``method="held_torque"`` (native rollout of
held torques, trimmed once per cycle, see :mod:`magsail_mj.concepts.msac.drive`) apply only
forces held over each step and keep it to round-off (measured ~2·10⁻⁹ N m s per cycle, 2·10⁻⁶
per simulated second). With the joint servos of the replay, RK4 lets it drift steadily:
measured 0.08 N m s per simulated second at δt = 5 µs, i.e. about 2·10⁻⁸ of the momentum the
wings exchange with the bus each stroke, but over 600 s it would add a spurious bus rate of
~0.5 % of the secular rate. For the replay the runner therefore projects the state back onto
zero total momentum at every chunk boundary (every ``chunk_cycles`` cycles, default 0.2 s) and
reports how much it removed; the stroboscopic series keeps the momentum at every cycle start
(``strobe_angmom_Nms``) for the spurious-yaw estimate of the summary.

With ``method="held_torque"`` the first ``calibration_cycles`` cycles of a run are the per-step
computed-torque loop from the rest state, the same steps the held-torque table was calibrated
on, so that the native held replay continues exactly from its orbit start.

Actuator demand: the running sums of the squared joint forces give their RMS
(``run_joint_force_rms``, per joint, over every step).

The ``records`` go to a :class:`~magsail_mj.records.Recorder` (chunk buffers, streamed to the
run's Zarr store when :meth:`MsacRunner.run` is given ``records_path``); the other series are
bounded (windows) or one value per cycle and stay in memory.

Long runs checkpoint (data only, :mod:`magsail_mj.checkpoint`: the physics state, the replay
table, the accumulators and the record count at chunk boundaries, with the run's identity) and
resume exactly: the record store is cut to the checkpoint's count and chunked rollouts restart
from the full physics state, so a resumed run equals an uninterrupted one. A checkpoint of
another config or build is refused.

Divergence: MuJoCo's automatic reset is off (:mod:`magsail_mj.divergence`), so a bad step stays
in the rolled-out states; after each chunk the first state that is not finite or above 1e10 (or a
control that is) is found and the run ends ``"diverged"`` at its time, keeping the records up to
it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Mapping

import mujoco
import numpy as np

from magsail_mj.concepts.msac.metrics import lowpass
from magsail_mj.concepts.msac.cycle import CyclePath, cycle_state
from magsail_mj.concepts.msac.drive import (
    ComputedTorque,
    HeldTorqueTable,
    desired_shape,
    held_torque_table,
    replay_table,
    servo_rates,
    set_initial_state,
    shape_vector,
    steps_per_cycle,
)
from magsail_mj.checkpoint import CheckpointError, StateWalker, restore_state, run_identity
from magsail_mj.divergence import WarningWatch, disable_autoreset, first_bad_row, route_mujoco_warnings
from magsail_mj.concepts.msac.mjcf import shape_indices
from magsail_mj.records import Recorder, StoreRecords
from magsail_mj.sim import RunResult, SteppedRun, WholeRun, open_run_records, progress_bar
from mujoco import rollout as mj_rollout

__all__ = ["MsacRunner", "StaticRunner"]

_FP = mujoco.mjtState.mjSTATE_FULLPHYSICS
#: the variables of the records (``t`` first)
RECORD_NAMES = ["t", "qpos", "qvel", "omega_world_rad_s", "angmom_Nms", "joint_force", "phase"]
#: the drive methods (``drive.method``)
METHODS = ("replay", "computed_torque", "held_torque")


@dataclass
class _Acc:
    """Accumulators of one run (lists of per-chunk arrays and running maxima; the records are in
    the runner's :class:`~magsail_mj.records.Recorder`)."""

    strobe: dict[str, list] = field(default_factory=dict)
    win: dict[str, list] = field(default_factory=dict)
    omega_blocks: list = field(default_factory=list)
    block_carry: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cycle_carry: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cyc_min: list = field(default_factory=list)
    cyc_max: list = field(default_factory=list)
    L0: np.ndarray | None = None
    drift_max: float = 0.0
    drift_z_max: float = 0.0
    hinge_peak: float = 0.0
    slide_peak: float = 0.0
    track_max: np.ndarray = field(default_factory=lambda: np.zeros(4))
    frc_sq_sum: np.ndarray = field(default_factory=lambda: np.zeros(4))
    frc_count: int = 0
    proj_sum: np.ndarray = field(default_factory=lambda: np.zeros(6))
    proj_max: float = 0.0
    proj_count: int = 0

    def add(self, store: dict[str, list], **arrays: np.ndarray) -> None:
        for k, v in arrays.items():
            store.setdefault(k, []).append(np.array(v, copy=True))


@dataclass
class MsacRunner(SteppedRun):
    """Run an MSAC model along its cycle (see module docs).

    Attributes:
      model: compiled MSAC model (owned by the runner; ``opt`` is used as set).
      path: the prescribed cycle.
      duration_s: simulated time [s].
      method: ``held_torque`` (native rollout of held torques, trimmed once per cycle),
        ``replay`` (native rollout with joint servos) or ``computed_torque`` (Python per step).
      record_every: record decimation [steps].
      omega_c_dt: computed-torque bandwidth ``ω_c δt``.
      calibration_cycles: computed-torque cycles before the replay table is taken.
      chunk_cycles: cycles per rollout call.
      window_s: length of each full-rate window [s].
      omega_sample_hz: minimum rate of the block-averaged ``ω_z`` fed to the filter [Hz].
      lowpass_order, lowpass_cutoff_hz: Butterworth order and cutoff [Hz].
      checkpoint_every_s: checkpoint interval in simulated seconds (0 = none).
      momentum_projection: zero the total momentum at every chunk boundary (see
        :meth:`_project`); the removed drift is reported.
    """

    model: mujoco.MjModel
    path: CyclePath
    duration_s: float
    method: Literal["replay", "computed_torque", "held_torque"] = "replay"
    record_every: int = 200
    omega_c_dt: float = 0.2
    calibration_cycles: int = 3
    chunk_cycles: int = 200
    window_s: float = 0.02
    omega_sample_hz: float = 20e3
    lowpass_order: int = 4
    lowpass_cutoff_hz: float = 10.0
    checkpoint_every_s: float = 0.0
    momentum_projection: bool = True
    identity: dict[str, Any] = field(default_factory=lambda: run_identity(None))

    #: records stream to a store given to :meth:`run` (``records_path``)
    streams_records = True

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method: must be one of {list(METHODS)}, got {self.method!r}")
        if int(self.record_every) != self.record_every or self.record_every < 1:
            raise ValueError(f"record_every: must be an integer >= 1, got {self.record_every!r}")
        if int(self.chunk_cycles) != self.chunk_cycles or self.chunk_cycles < 1:
            raise ValueError(f"chunk_cycles: must be an integer >= 1, got {self.chunk_cycles!r}")
        m = self.model
        route_mujoco_warnings()
        disable_autoreset(m)
        self.dt = float(m.opt.timestep)
        self.N = steps_per_cycle(self.path, self.dt)
        self.n_steps = int(round(self.duration_s / self.dt))
        if self.n_steps < 1:
            raise ValueError(f"duration_s: must cover at least one step of {self.dt:g} s, got {self.duration_s!r}")
        self.ix = shape_indices(m)
        self.nq, self.nv, self.nu = m.nq, m.nv, m.nu
        self.nstate = mujoco.mj_stateSize(m, _FP)
        # ω_z block: the largest divisor of N whose length is at most 1/omega_sample_hz
        target = max(1, int(math.floor(1.0 / (self.omega_sample_hz * self.dt) + 1e-9)))
        self.block = max(b for b in range(1, self.N + 1) if self.N % b == 0 and b <= target)
        self.q_des_cycle, _, _ = desired_shape(self.path, np.arange(self.N) * self.dt)
        w = int(round(self.window_s / self.dt))
        mid = int(round(self.n_steps / 2 / self.N)) * self.N
        end = max(0, (self.n_steps - w) // self.N * self.N)
        ranges = sorted(
            {(0, min(w, self.n_steps)), (mid, min(mid + w, self.n_steps)), (end, min(end + w, self.n_steps))}
        )
        merged: list[list[int]] = []
        for a, b in ranges:
            if a >= b:
                continue
            if merged and a <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], b)
            else:
                merged.append([a, b])
        self.windows = [tuple(r) for r in merged]
        self.table = None
        self._ct: ComputedTorque | None = None
        #: held_torque: the first calibration cycles run the computed-torque loop (see _advance)
        self._ct_steps = int(self.calibration_cycles) * self.N if self.method == "held_torque" else 0
        self.data = mujoco.MjData(m)
        # the Python-side state of a run (baseline: fresh accumulators, no table yet)
        self._walker = StateWalker({"acc": _Acc(), "table": None, "ct": None})
        self._walker.baseline()
        self.recorder = Recorder(list(RECORD_NAMES))
        self.reset()

    # ------------------------------------------------------------------ chunk bookkeeping
    def _process(self, acc: _Acc, k0: int, S: np.ndarray, sd: np.ndarray, ctrl: np.ndarray) -> None:
        """Fold the step-start states ``S`` (n, nstate), sensors ``sd`` and controls of steps
        ``k0 … k0+n−1`` into the accumulators (vectorised)."""
        ix, nq, nv = self.ix, self.nq, self.nv
        n = S.shape[0]
        steps = k0 + np.arange(n)
        t = steps * self.dt
        qpos = S[:, 1 : 1 + nq]
        qvel = S[:, 1 + nq : 1 + nq + nv]
        L = sd[:, ix["angmom"]]
        w_world = sd[:, ix["angvel"]]
        frc = sd[:, ix["frc"]]
        if acc.L0 is None:
            acc.L0 = L[0].copy()
        dL = L - acc.L0
        acc.drift_max = max(acc.drift_max, float(np.sqrt((dL * dL).sum(axis=1)).max()))
        acc.drift_z_max = max(acc.drift_z_max, float(np.abs(dL[:, 2]).max()))
        acc.hinge_peak = max(acc.hinge_peak, float(np.abs(frc[:, [0, 2]]).max()))
        acc.slide_peak = max(acc.slide_peak, float(np.abs(frc[:, [1, 3]]).max()))
        # a strict left fold over the steps (not a pairwise sum per chunk), so the total does not
        # depend on where chunks start: a run stopped mid-chunk and resumed sums the same way
        acc.frc_sq_sum = np.add.accumulate(np.vstack([acc.frc_sq_sum[None], frc * frc]), axis=0)[-1]
        acc.frc_count += n
        err = np.abs(qpos[:, ix["qpos"]] - self.q_des_cycle[steps % self.N])
        acc.track_max = np.maximum(acc.track_max, err.max(axis=0))

        sel = steps % self.N == 0
        if sel.any():
            acc.add(
                acc.strobe,
                strobe_t=t[sel],
                strobe_quat=qpos[sel, 3:7],
                strobe_shape=qpos[sel][:, ix["qpos"]],
                strobe_angmom_Nms=L[sel],
            )
        # the per-step series both the records and the full-rate windows keep
        series = {"qpos": qpos, "qvel": qvel, "omega_world_rad_s": w_world, "angmom_Nms": L, "joint_force": frc}
        sel = steps % self.record_every == 0
        if sel.any():
            self.recorder.extend(
                {
                    "t": t[sel],
                    **{name: v[sel] for name, v in series.items()},
                    "phase": cycle_state(self.path, t[sel]).phase + 1,
                }
            )
        for wid, (a, b) in enumerate(self.windows):
            sel = (steps >= a) & (steps < b)
            if sel.any():
                acc.add(
                    acc.win,
                    win_t=t[sel],
                    win_id=np.full(int(sel.sum()), wid),
                    **{f"win_{name}": v[sel] for name, v in series.items()},
                    win_ctrl=ctrl[sel],
                )
        wz = np.concatenate([acc.block_carry, w_world[:, 2]])
        nb = wz.size // self.block
        if nb:
            acc.omega_blocks.append(wz[: nb * self.block].reshape(nb, self.block).mean(axis=1))
        acc.block_carry = wz[nb * self.block :].copy()
        # per-cycle extremes of the raw ω_z over every cycle completed by this chunk (the part of a
        # cycle a chunk ends in is carried to the next, so the split of a run into chunks is invisible)
        seq = np.concatenate([acc.cycle_carry, w_world[:, 2]])
        first = (-(k0 - acc.cycle_carry.size)) % self.N
        ncyc = (seq.size - first) // self.N
        if ncyc:
            blk = seq[first : first + ncyc * self.N].reshape(ncyc, self.N)
            acc.cyc_min.append(blk.min(axis=1))
            acc.cyc_max.append(blk.max(axis=1))
        acc.cycle_carry = seq[first + ncyc * self.N :].copy()

    # ------------------------------------------------------------------ momentum projection
    def _project(self, data: mujoco.MjData, state: np.ndarray, acc: _Acc) -> np.ndarray:
        r"""Remove the integrator's drift of the total momentum at a chunk boundary.

        For a floating base the generalised momentum of the free-joint coordinates,
        ``p_b = (M v)_b``, is the total linear and angular momentum (in the free joint's
        coordinates); it is zero at the start and the exact dynamics keep it zero (all drive
        forces are internal joint forces). Setting ``v_b ← v_b − M_bb⁻¹ p_b`` restores
        ``p_b = 0`` by changing only the bus velocity (a standard projection onto the invariant,
        Hairer, Lubich & Wanner, *Geometric Numerical Integration*, Sec. IV.4). The removed ``p_b``
        (the drift accumulated over the chunk) is kept in ``run_momentum_projection_*``.
        """
        m, nq, nv = self.model, self.nq, self.nv
        mujoco.mj_setState(m, data, state, _FP)
        mujoco.mj_fwdPosition(m, data)
        M = np.zeros((nv, nv))
        mujoco.mj_fullM(m, data, M)
        b = self.ix["bus_dof"]
        v = state[1 + nq : 1 + nq + nv]
        p_b = (M @ v)[b]
        dv = -np.linalg.solve(M[np.ix_(b, b)], p_b)
        out = state.copy()
        out[1 + nq + b] += dv
        acc.proj_sum = acc.proj_sum + p_b
        acc.proj_max = max(acc.proj_max, float(np.abs(p_b).max()))
        acc.proj_count += 1
        return out

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to t = 0: the cycle's initial state and empty accumulators (a computed replay
        table is kept: it depends on the model and the cycle only)."""
        set_initial_state(self.model, self.data, self.path)
        self._state = np.empty(self.nstate)
        mujoco.mj_getState(self.model, self.data, self._state, _FP)
        self.acc = _Acc()
        self.recorder.truncate(0)
        self.step_index = 0
        self._begin()
        self._wall_s = 0.0

    def _begin(self) -> None:
        self.status, self.message = "running", ""
        self._watch = WarningWatch(self.data)

    @property
    def time(self) -> float:
        """Simulated time of the current state [s]."""
        return self.step_index * self.dt

    def get_state(self) -> dict[str, Any]:
        """The whole state as plain data: the step, MuJoCo's full physics state (``mj_state``,
        ``mjSTATE_FULLPHYSICS``) and the snapshot of the accumulators, replay table and
        computed-torque state (``python_tree``, ``python_arrays``)."""
        self._walker.roots.update(acc=self.acc, table=self.table, ct=self._ct)
        tree, arrays = self._walker.snapshot()
        return {
            "step": self.step_index,
            "mj_state": self._state.copy(),
            "n_records": len(self.recorder),
            "python_tree": tree,
            "python_arrays": arrays,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        mj_state = np.asarray(state["mj_state"], dtype=float)
        step = int(state["step"])
        if mj_state.shape != (self.nstate,) or not 0 <= step <= self.n_steps:
            raise ValueError(
                f"state: not a state of this model within sim.duration_s (step {step}, mj_state shape {mj_state.shape})"
            )
        self._walker.roots.update(acc=self.acc, table=self.table, ct=self._ct)
        restore_state(self._walker, state["python_tree"], state["python_arrays"])
        self.acc, self.table, self._ct = (self._walker.roots[k] for k in ("acc", "table", "ct"))
        self._state = mj_state.copy()
        self.recorder.truncate(min(int(state.get("n_records", len(self.recorder))), len(self.recorder)))
        self.step_index = step
        self._begin()

    def records(self) -> Mapping[str, np.ndarray]:
        """The records and run series so far (see module docs): a dict, or, when the records
        stream to a store, a :class:`~magsail_mj.records.StoreRecords` reading them lazily with the
        other series in memory (``extra``)."""
        series = self._records(self.acc)
        series["run_replay_settle_change"] = np.array(self.table.settle_change if self.table else np.nan)
        records = self.recorder.arrays()
        if isinstance(records, StoreRecords):
            return StoreRecords(records.path, extra=series)
        return {**records, **series}

    # ------------------------------------------------------------------ checkpoints
    def _save(self, path: Path) -> None:
        self._write_checkpoint(path, mj_state_key="state")

    def _load(self, path: Path, store: Path | None) -> None:
        header, arrays, extra = self._read_checkpoint(path)
        k = int(header["step"])
        if "state" not in extra or extra["state"].shape != (self.nstate,) or not 0 <= k <= self.n_steps:
            raise CheckpointError(f"checkpoint: {path} does not hold a state of this model within sim.duration_s")
        if "n_records" not in header or store is None:
            raise CheckpointError(f"checkpoint: {path} holds no record count or has no record store")
        self._reopen_store(path, store, header)
        self.set_state(
            {
                "step": k,
                "mj_state": extra["state"],
                "n_records": int(header["n_records"]),
                "python_tree": header["state_tree"],
                "python_arrays": arrays,
            }
        )
        self._wall_s = float(header.get("wall_s", 0.0))

    # ------------------------------------------------------------------ stepping
    def _cycle_controls(self) -> np.ndarray:
        """The (N, nu) controls of one cycle (the replay table's, or the servo set-points with the
        computed torque added per step); builds the table or the computed-torque law on first use."""
        m = self.model
        if self.method == "replay":
            if self.table is None:
                self.table = replay_table(
                    m, self.path, omega_c_dt=self.omega_c_dt, calibration_cycles=self.calibration_cycles
                )
            return self.table.ctrl
        if self.method == "held_torque":
            if self.table is None:
                self.table = held_torque_table(
                    m, self.path, omega_c_dt=self.omega_c_dt, calibration_cycles=self.calibration_cycles
                )
            return self.table.ctrl
        if self._ct is None:
            self._ct = ComputedTorque(m, self.path, omega_c_dt=self.omega_c_dt)
        cyc_ctrl = np.zeros((self.N, self.nu))
        cyc_ctrl[:, self.ix["servo"]] = servo_rates(m, self.path, self.N)
        return cyc_ctrl

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
        """Run from the current state to ``duration_s`` (or ``stop_after_s``), checkpointing at the
        chunk boundaries after every ``checkpoint_every_s``; records stream to ``records_path`` (a
        checkpointed run without it: ``<checkpoint stem>.records.zarr``), as in
        :meth:`magsail_mj.sim.Simulation.run`."""
        ckpt = open_run_records(
            self.recorder,
            checkpoint_path=checkpoint_path,
            records_path=records_path,
            records_attrs=records_attrs,
            restore=self._load if resume else None,
        )
        k_start = self.step_index
        stop_step = self.n_steps if stop_after_s is None else min(self.n_steps, int(math.ceil(stop_after_s / self.dt)))
        chunk = int(self.chunk_cycles) * self.N
        bar = None
        if progress and self.n_steps > 10 * chunk:
            bar = progress_bar(total=self.n_steps, initial=k_start, mininterval_s=5.0, unit_scale=True)
        self._advance_with_bar(stop_step, bar, ckpt=ckpt)
        if self.status == "running":
            self.status, self.message = "stopped", f"stopped at t = {self.time:.6f} s (stop_after_s)"
            if ckpt is not None:
                self._save(ckpt)
        return self._result()

    def _advance(self, stop_step: int, *, ckpt: Path | None = None, bar: Any = None) -> None:
        """Roll out from the current step to ``stop_step`` in chunks that end at the absolute chunk
        boundaries (multiples of ``chunk_cycles`` cycles), so the momentum projection and the
        checkpoints fall on the same steps however the run is split."""
        m, data = self.model, self.data
        dt, N = self.dt, self.N
        wall0 = time.perf_counter()
        cyc_ctrl = self._cycle_controls()
        chunk = int(self.chunk_cycles) * N
        ctrl_chunk = np.tile(cyc_ctrl, (int(self.chunk_cycles), 1))
        ck_every = int(round(self.checkpoint_every_s / dt)) if self.checkpoint_every_s > 0 else 0
        k, state, acc = self.step_index, self._state, self.acc
        next_ck = (k // ck_every + 1) * ck_every if ck_every else None
        st_buf = np.empty((1, chunk, self.nstate))
        sd_buf = np.empty((1, chunk, m.nsensordata))
        pool = mj_rollout.Rollout(nthread=0)
        if self.method != "replay":
            m.opt.disableactuator |= 1 << 1  # computed or held torque alone: servos off
        try:
            while k < stop_step:
                n = min(chunk - k % chunk, stop_step - k)
                start_up = self.method == "held_torque" and k < self._ct_steps
                if start_up:
                    n = min(n, self._ct_steps - k)
                ctrl = (
                    ctrl_chunk[(k % N) : (k % N) + n]
                    if (k % N) + n <= chunk
                    else np.tile(cyc_ctrl, (n // N + 2, 1))[(k % N) : (k % N) + n]
                )
                if self.method == "replay":
                    st = st_buf[:, :n] if n == chunk else np.empty((1, n, self.nstate))
                    sd = sd_buf[:, :n] if n == chunk else np.empty((1, n, m.nsensordata))
                    pool.rollout(m, data, state[None], ctrl[None], state=st, sensordata=sd)
                    post = st[0]
                    sens = sd[0]
                elif self.method == "held_torque" and not start_up:
                    ctrl, post, sens = self._held_segment(pool, state, k, ctrl)
                else:
                    ctrl, post, sens = self._ct_segment(state, k, ctrl)
                S = np.vstack([state[None], post[:-1]])
                warned = self._watch.raised()
                bad_state, bad_ctrl = first_bad_row(post[:, 1:]), first_bad_row(ctrl)
                if warned or bad_state is not None or bad_ctrl is not None:
                    # post[i] is the state at step k + i + 1; a bad control acts from step k + i
                    cands = [i + 1 for i in (bad_state,) if i is not None] + [i for i in (bad_ctrl,) if i is not None]
                    bad = min(cands) if cands else n
                    cause = (
                        "a control is not finite or above 1e10 (raise the ff gear)"
                        if bad_ctrl is not None and bad == bad_ctrl
                        else "the state is not finite or above 1e10"
                    )
                    self.status = "diverged"
                    self.message = f"diverged at t = {(k + bad) * dt:.6g} s: {cause}" + (
                        f" (MuJoCo warnings {', '.join(warned)})" if warned else ""
                    )
                    self._process(acc, k, S[:bad], sens[:bad], ctrl[:bad])
                    k += bad
                    break
                self._process(acc, k, S, sens, ctrl)
                state = post[-1].copy()
                k += n
                if self.momentum_projection and (k % chunk == 0 or k == self.n_steps):
                    state = self._project(data, state, acc)
                if bar is not None:
                    bar.update(n)
                if ckpt is not None and next_ck is not None and next_ck <= k < self.n_steps:
                    self.step_index, self._state = k, state
                    self._wall_s += time.perf_counter() - wall0
                    wall0 = time.perf_counter()
                    self._save(ckpt)
                    next_ck = (k // ck_every + 1) * ck_every
            if self.status == "running" and k == self.n_steps:
                # the final state (t = duration) as a last sample: sensors from mj_forward
                mujoco.mj_setState(m, data, state, _FP)
                data.ctrl[:] = cyc_ctrl[k % N]
                mujoco.mj_forward(m, data)
                self._process_final(acc, k, state, data.sensordata.copy(), cyc_ctrl[k % N])
                self.status = "completed"
        finally:
            pool.close()
            if self.method != "replay":
                m.opt.disableactuator &= ~(1 << 1)
            self.step_index, self._state = k, state
            self._wall_s += time.perf_counter() - wall0

    def _ct_segment(self, state: np.ndarray, k: int, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steps ``k … k+n−1`` (``n = len(ctrl)``) of the per-step computed-torque loop from
        ``state`` (servos off): the controls applied, the states after each step and the sensors
        (computed at each step-start state)."""
        m, data = self.model, self.data
        if self._ct is None:
            self._ct = ComputedTorque(m, self.path, omega_c_dt=self.omega_c_dt)
        ct = self._ct
        n = ctrl.shape[0]
        post = np.empty((n, self.nstate))
        sens = np.empty((n, m.nsensordata))
        ctrl = ctrl.copy()
        mujoco.mj_setState(m, data, state, _FP)
        for i in range(n):
            ctrl[i, self.ix["ff"]] = ct.torque(data, k + i) / ct.gear
            data.ctrl[:] = ctrl[i]
            mujoco.mj_step(m, data)
            sens[i] = data.sensordata
            mujoco.mj_getState(m, data, post[i], _FP)
        return ctrl, post, sens

    def _held_segment(
        self, pool: Any, state: np.ndarray, k: int, ctrl: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Roll out steps ``k … k+n−1`` (``n = len(ctrl)``) of the ``held_torque`` drive from
        ``state``, one cycle at a time: at every cycle start the trim of that cycle is set from
        the shape vector (:meth:`HeldTorqueTable.trim`) and its held torques added to the nominal
        controls. Returns the controls applied, the states after each step and the sensors."""
        table: HeldTorqueTable = self.table
        m, N = self.model, self.N
        gear = m.actuator_gear[self.ix["ff"], 0]
        ctrl = ctrl.copy()
        post = np.empty((ctrl.shape[0], self.nstate))
        sens = np.empty((ctrl.shape[0], m.nsensordata))
        i = 0
        while i < ctrl.shape[0]:
            j = min(ctrl.shape[0], i + N - (k + i) % N)
            if (k + i) % N == 0:
                table.trim(shape_vector(m, state, ix=self.ix))
            ctrl[i:j, self.ix["ff"]] += table.trim_torque()[(k + i) % N : (k + i) % N + j - i] / gear
            st, sd = pool.rollout(m, self.data, state[None], ctrl[None, i:j])
            post[i:j], sens[i:j] = st[0], sd[0]
            state = st[0, -1]
            i = j
        return ctrl, post, sens

    def _process_final(self, acc: _Acc, k: int, state: np.ndarray, sens: np.ndarray, ctrl: np.ndarray) -> None:
        """Add the end state to the strobe (if a cycle start) and the records (always)."""
        ix, nq, nv = self.ix, self.nq, self.nv
        qpos, qvel = state[1 : 1 + nq], state[1 + nq : 1 + nq + nv]
        t = np.array([k * self.dt])
        if k % self.N == 0:
            acc.add(
                acc.strobe,
                strobe_t=t,
                strobe_quat=qpos[None, 3:7],
                strobe_shape=qpos[None, ix["qpos"]],
                strobe_angmom_Nms=sens[None, ix["angmom"]],
            )
        self.recorder.extend(
            dict(
                t=t,
                qpos=qpos[None],
                qvel=qvel[None],
                omega_world_rad_s=sens[None, ix["angvel"]],
                angmom_Nms=sens[None, ix["angmom"]],
                joint_force=sens[None, ix["frc"]],
                phase=cycle_state(self.path, t).phase + 1,
            )
        )
        dL = sens[ix["angmom"]] - acc.L0
        acc.drift_max = max(acc.drift_max, float(np.linalg.norm(dL)))
        acc.drift_z_max = max(acc.drift_z_max, float(abs(dL[2])))

    def _records(self, acc: _Acc) -> dict[str, np.ndarray]:
        """Concatenate the accumulators into the run's series other than the records (see module docs)."""
        cat = lambda parts: np.concatenate(parts) if parts else np.zeros(0)  # noqa: E731
        out: dict[str, np.ndarray] = {}
        out.update({k: cat(v) for k, v in acc.strobe.items()})
        out.update({k: cat(v) for k, v in acc.win.items()})
        wz = cat(acc.omega_blocks)
        fs = 1.0 / (self.block * self.dt)
        out["omega_block_hz"] = np.array(fs)
        if wz.size:
            tb = (np.arange(wz.size) * self.block + 0.5 * (self.block - 1)) * self.dt
            dec = max(1, int(round(fs / 1000.0)))
            padlen = 3 * (2 * math.ceil(self.lowpass_order / 2) + 1)  # sosfiltfilt's default
            if wz.size > padlen and self.lowpass_cutoff_hz < fs / 2:
                wf = lowpass(wz, fs_hz=fs, cutoff_hz=self.lowpass_cutoff_hz, order=self.lowpass_order)
            else:
                wf = np.full_like(wz, np.nan)
            out["omega_filt_t"] = tb[::dec]
            out["omega_z_filtered_rad_s"] = wf[::dec]
            out["omega_z_block_mean_rad_s"] = np.array(wz.mean())
        out["omega_z_cycle_min_rad_s"] = cat(acc.cyc_min)
        out["omega_z_cycle_max_rad_s"] = cat(acc.cyc_max)
        out["run_angmom_drift_max_Nms"] = np.array(acc.drift_max)
        out["run_angmom_drift_z_max_Nms"] = np.array(acc.drift_z_max)
        out["run_hinge_torque_peak_Nm"] = np.array(acc.hinge_peak)
        out["run_slide_force_peak_N"] = np.array(acc.slide_peak)
        out["run_joint_force_rms"] = np.sqrt(acc.frc_sq_sum / max(acc.frc_count, 1))
        out["run_tracking_error_max"] = acc.track_max.copy()
        out["run_steps_per_cycle"] = np.array(self.N)
        out["run_momentum_projection_sum"] = acc.proj_sum.copy()
        out["run_momentum_projection_max"] = np.array(acc.proj_max)
        out["run_momentum_projection_count"] = np.array(acc.proj_count)
        return out


@dataclass
class StaticRunner(WholeRun):
    """A run with no dynamics (the ``lumped`` scenario): one record of the initial state."""

    model: mujoco.MjModel
    path: CyclePath

    def run_whole(self, *, progress: bool) -> RunResult:
        data = mujoco.MjData(self.model)
        set_initial_state(self.model, data, self.path)
        return RunResult(
            records={"t": np.zeros(1), "qpos": data.qpos.copy()[None]},
            status="completed",
            message="analytic scenario: no MuJoCo steps",
            t_end_s=0.0,
            steps=0,
            wall_time_s=0.0,
        )
