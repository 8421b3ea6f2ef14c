r"""The flexible truss lattice over a world axis: what Python does between two batched ``mj_step``\ s.

:class:`LatticeWorlds` is the truss part of a batch (:class:`magsail_mj.batch.runner.BatchSimulation`
drives it). Each step ``k`` (``t = k·δt``), for all N worlds at once, as
:class:`magsail_mj.sim.Simulation` does for one orbital truss run
(:class:`~magsail_mj.concepts.truss_magnetorquer.tasks.OrbitalTrussTask`):

1. :meth:`control`: when a sample is due, the rod controller of every live world
   (:class:`~magsail_mj.concepts.truss_magnetorquer.batch_control.RodControlWorlds`) at the
   particles' positions ``x_i = p_i + qpos_i`` (world axes; :class:`~magsail_mj.sim.BodyKinematics`
   of a lattice, element-wise) and the environment at t
   (:class:`~magsail_mj.batch.environment.EnvironmentStack`); the command is held in between;
2. :meth:`probes` (record steps): the single run's probes (``qpos`` and those of
   :func:`~magsail_mj.concepts.truss_magnetorquer.orbital.orbital_probes`), each world's by its own
   probe functions on its own rows, so every value is the single run's; then :meth:`failures`: the
   strut strain check of every live world at once (:func:`~magsail_mj.lattice.geometry.strain_check`'s
   ``(l/l0)² = |x_b − x_a|²/l0²`` with its :func:`numpy.einsum` per world, the largest
   ``|l/l0 − 1|`` at the largest or smallest ratio; beyond ``sim.max_strain`` it stops that world,
   ``structure_failed``, as :class:`~magsail_mj.divergence.StructureFailure` stops its single run);
3. :meth:`loads`: ``xfrc_applied`` zeroed, then tidal gravity and the rod force pairs of the held
   polarities (:class:`~magsail_mj.concepts.truss_magnetorquer.batch_loads.LatticeLoadWorlds`), at
   the step's start (``sim.load_timing = "start"``, the one timing a truss batch runs).

A stopped world keeps its ``xfrc_applied`` and controller state.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np

from magsail_mj.batch.environment import EnvironmentStack, EnvSamples
from magsail_mj.concepts.truss_magnetorquer.batch_control import RodControlWorlds, WorldEnv
from magsail_mj.concepts.truss_magnetorquer.batch_loads import LatticeLoadWorlds
from magsail_mj.loads.base import StepState

__all__ = ["LatticeWorlds"]

Probe = Callable[[StepState, Any], Any]


class LatticeWorlds:
    """The truss lattice of N worlds (module docstring).

    Args:
      pos0: (N, nbody, 3) each world's ``body_pos`` [m] (the particles' reference positions).
      particles: ``(bodies, qpos)`` slices of the particles' bodies and their ``qpos`` block.
      environments: the worlds' environments.
      loads: the worlds' tidal and rod loads.
      controller: the worlds' rod controllers.
      probes: each world's probe functions (``state, data → value``), the same names in every
        world, ``qpos`` excluded (recorded from the batch's ``qpos``).
      struts: (S, 2) the struts' end bodies (every world's lattice has the same struts).
      inv_rest_length_sq: (N, S) each world's ``1/l0²`` of every strut [1/m²].
      max_strain: (N,) each world's strain bound.
      timestep_s: δt [s].
    """

    def __init__(
        self,
        *,
        pos0: np.ndarray,
        particles: tuple[slice, slice],
        environments: EnvironmentStack,
        loads: LatticeLoadWorlds,
        controller: RodControlWorlds,
        probes: Sequence[dict[str, Probe]],
        struts: np.ndarray,
        inv_rest_length_sq: np.ndarray,
        max_strain: np.ndarray,
        timestep_s: float,
    ) -> None:
        self.pos0 = np.asarray(pos0, dtype=float)
        self.bodies, self.q_block = particles
        self.env = environments
        self.lds = loads
        self.ctl = controller
        self.world_probes = [dict(p) for p in probes]
        self.probe_names = ("qpos", *self.world_probes[0])
        self.strut_a, self.strut_b = np.asarray(struts[:, 0]), np.asarray(struts[:, 1])
        self.inv_l0_sq = np.asarray(inv_rest_length_sq, dtype=float)
        self.max_strain = np.asarray(max_strain, dtype=float)
        self.dt = float(timestep_s)
        self.n = len(self.world_probes)
        self.live = np.ones(self.n, dtype=bool)
        self.reset()

    def reset(self) -> None:
        """The state of the build: controllers without a sample, nothing cached."""
        self.ctl.reset()
        self._cache: tuple[int, np.ndarray, EnvSamples, list[WorldEnv]] | None = None

    def set_live(self, live: np.ndarray) -> None:
        """Which worlds still run (the others keep their state)."""
        self.live = live

    # ------------------------------------------------------------------ the step's state
    def _state(self, step: int, qpos: np.ndarray) -> tuple[np.ndarray, EnvSamples, list[WorldEnv]]:
        """Body positions (N, nbody, 3) [m], the environment and each world's view of it at step
        ``step`` (formed once per step)."""
        if self._cache is None or self._cache[0] != step:
            pos = self.pos0.copy()
            n = pos[:, self.bodies].shape[1]
            np.add(self.pos0[:, self.bodies], qpos[:, self.q_block].reshape(self.n, n, 3), out=pos[:, self.bodies])
            env = self.env.sample(step * self.dt)
            B, r = env.B_eci, env.r_ref_eci
            views = [WorldEnv(B[k], r[k]) for k in range(self.n)]
            self._cache = (step, pos, env, views)
        return self._cache[1:]

    # ------------------------------------------------------------------ the step
    def control(self, step: int, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray) -> None:
        """The rod controllers' sample at step ``step`` when one is due (the model has no actuators:
        ``ctrl`` is not written)."""
        if self.ctl.due(step):
            pos, env, views = self._state(step, qpos)
            self.ctl.sample(step, pos, env.B_eci, views, self.live)

    def probes(self, step: int, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
        """The probes' values at step ``step`` (after :meth:`control`), (N, …) each; a stopped
        world's rows are zeros (the records skip them)."""
        pos, _, views = self._state(step, qpos)
        t = step * self.dt
        names = self.probe_names[1:]
        rows: dict[int, list[Any]] = {}
        for k in np.flatnonzero(self.live).tolist():
            s = StepState(t=t, pos=pos[k], vel=None, xquat=None, omega=None, env=views[k], ctrl=self.ctl.command(k))
            probes = self.world_probes[k]
            rows[k] = [np.asarray(probes[name](s, None)) for name in names]
        first = next(iter(rows.values()))
        out: dict[str, np.ndarray] = {"qpos": qpos.copy()}
        for i, name in enumerate(names):
            column = np.zeros((self.n, *first[i].shape), dtype=first[i].dtype)
            for k, values in rows.items():
                column[k] = values[i]
            out[name] = column
        return out

    def failures(self, step: int, qpos: np.ndarray, live: np.ndarray) -> dict[int, str]:
        """The live worlds whose structure failed at the record of step ``step``: world → the single
        run's message (the largest strut strain beyond ``sim.max_strain``)."""
        pos, _, _ = self._state(step, qpos)
        t = step * self.dt
        rows = np.flatnonzero(live)
        p = pos[rows]
        r = p.take(self.strut_b, axis=1)
        r -= p.take(self.strut_a, axis=1)
        ratio2 = np.einsum("nij,nij->ni", r, r) * self.inv_l0_sq[rows]
        i_max, i_min = np.argmax(ratio2, axis=1).tolist(), np.argmin(ratio2, axis=1).tolist()
        out = {}
        for j, k in enumerate(rows.tolist()):
            stretch, squeeze = math.sqrt(ratio2[j, i_max[j]]) - 1.0, 1.0 - math.sqrt(ratio2[j, i_min[j]])
            strain, strut = (stretch, i_max[j]) if stretch >= squeeze else (squeeze, i_min[j])
            if not strain <= self.max_strain[k]:
                out[k] = (
                    f"strut {strut} strain {strain:.3g} exceeds sim.max_strain {self.max_strain[k]:g} at t = {t:.6g} s"
                )
        return out

    def loads(self, step: int, qpos: np.ndarray, qvel: np.ndarray, xfrc: np.ndarray) -> None:
        """``xfrc_applied`` of step ``step``: zero, then tidal gravity and the rods' force pairs."""
        pos, env, _ = self._state(step, qpos)
        live = self.live
        pol = self.ctl.polarity if live.all() else np.where(live[:, None], self.ctl.polarity, 0).astype(np.int8)
        if live.all():
            xfrc[...] = 0.0
            self.lds.add(pos, env.r_ref_eci, env.B_eci, pol, xfrc)
            return
        wrench = np.zeros(xfrc.shape)
        self.lds.add(pos, env.r_ref_eci, env.B_eci, pol, wrench)
        np.copyto(xfrc, wrench, where=live[:, None, None])

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """The Python-side state as plain data: the controllers' (:meth:`RodControlWorlds.get_state`)."""
        return {"controller": self.ctl.get_state()}

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        self.ctl.set_state(state["controller"])
        self._cache = None
