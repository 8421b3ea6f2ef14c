r"""The CNUSAIL cubesat's compiled loads in a batch of worlds (``sim.loads = "compiled"``).

With compiled loads the cubesat's disturbance and magnetorquer torques, the magnetorquer blanking
and the wheel drivers' per-step part are the MuJoCo plugin ``magsail.cubesat_loads``
(:mod:`magsail_mj.concepts.cnusail.compiled`, ``magsail_mj/compiled/cubesat_loads.c``) inside each
world's ``mj_step``; Python runs only at the controller's samples and the records, and the batch
steps every world natively in between (:class:`magsail_mj.batch.runner.BatchSimulation` with a
plant whose ``native_steps`` is true).

**Per world.** The plugin reads its parameter block (inertia, residual dipole, drag facets, sail
optics, wheel constants, environment models: :data:`~magsail_mj.concepts.cnusail.compiled.PARAM_FIELDS`)
and the environment's coefficient table from two custom numerics of the *model*, and its held
command and step memory from the plugin state of each world's ``MjData`` (a row of the batch's
integration state). The model's numerics are shared by every world that runs on one ``MjModel``,
so each world runs on a model of its own numbers (:func:`world_models`, handed to
:meth:`mujoco.batch.Batch.set_models`): per distinct MJCF (masses, inertias, geometry) one model
is compiled with the plugin, exactly as the world's single run compiles it, and per distinct
(MJCF, environment, parameter block) a copy of it gets that world's parameter block and table
written into its ``numeric_data``. Worlds with equal numbers share one model (a shared epoch and
parameters: one model for all), so memory grows with the distinct environments (≈ 0.7 MB of
table each for three orbits), as on the Python path. Every key a batch lets differ per world is
thereby per world with compiled loads too; what must be shared is the Python path's list
(:data:`~magsail_mj.concepts.cnusail.batch.LOCKSTEP_KEYS`, ``sim.load_timing``, and ``sim.loads``
itself).

**The step.** :class:`CompiledCubesatWorlds` is the plant: at each controller sample (every
``gcd(n_att, n_cycle)`` steps, the single compiled run's schedule) the worlds' environments are
sampled at t, the B-dot controller over the world axis
(:class:`~magsail_mj.concepts.cnusail.batch_control.BdotWorlds`) takes the samples due, and each
live world's held dipole and wheel command go into its plugin state (``DIPOLE``, ``WHEEL_CMD``,
``STALE``); at a record, the probes are the single compiled run's — the controller's values and
the plugin's torques and motor torques at the record's state, from the library's
``magsail_cubesat_probe_rows`` (one C call for every world, each on its own model). Each world
then equals its single run with ``sim.loads = "compiled"`` bit for bit.
"""

from __future__ import annotations

import copy
import ctypes
import math
from typing import Any, Sequence

import mujoco
import numpy as np

from magsail_mj.batch.environment import EnvironmentStack
from magsail_mj.compiled import load_plugin
from magsail_mj.concepts.cnusail.batch_control import BdotWorlds
from magsail_mj.concepts.cnusail.batch_plant import PROBES, controller_probes
from magsail_mj.concepts.cnusail.compiled import LIBRARY, STATE_OFFSETS, CompiledCubesat, cubesat_params
from magsail_mj.concepts.cnusail.model import CnusailModel
from magsail_mj.config import ConfigError

__all__ = ["world_models", "CompiledCubesatWorlds", "PARAMS_NUMERIC", "TABLE_NUMERIC"]

PARAMS_NUMERIC = "magsail_cubesat_params"
TABLE_NUMERIC = "magsail_cubesat_table"

_S = STATE_OFFSETS


def _numeric_slice(model: mujoco.MjModel, name: str) -> slice:
    """The addresses of the custom numeric ``name`` in ``model.numeric_data``."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, name)
    if i < 0:
        raise ValueError(f"model: has no custom numeric {name!r}")
    adr = int(model.numeric_adr[i])
    return slice(adr, adr + int(model.numeric_size[i]))


def world_models(
    cubesats: Sequence[CnusailModel],
    bare_index: np.ndarray,
    *,
    timing: str,
) -> tuple[list[mujoco.MjModel], np.ndarray]:
    """Each world's model with the compiled loads (module docstring): ``(models, world_model)``,
    the distinct models (world 0's first) and each world's index in them.

    Args:
      cubesats: each world's built cubesat (its MJCF spec and model, environment, disturbances).
      bare_index: (N,) each world's index among the distinct MJCF models (worlds of one index have
        equal MJCF parameters).
      timing: ``sim.load_timing``.

    Raises:
      ConfigError: a world asks what the plugin does not model (named, ``world k:``), or its table
        or parameter block does not fit world 0's model.
    """
    bases: dict[int, CompiledCubesat] = {}
    models: list[mujoco.MjModel] = []
    keys: dict[tuple[int, int, bytes], int] = {}
    world_model = np.empty(len(cubesats), dtype=np.intp)
    for k, cs in enumerate(cubesats):
        ctl = cs.make_controller()
        try:
            params = cubesat_params(
                environment=cs.environment,
                disturbances=cs.disturbances,
                controller=ctl,
                body=cs.disturbances.body_id,
                qpos_adr=cs.idx.q_pos.start,
                dof_adr=cs.idx.v_lin.start,
                timing=timing,
            )
        except ValueError as err:
            raise ConfigError([f"world {k}: {err}"]) from None
        table = cs.environment._table.coef.ravel()
        b = int(bare_index[k])
        key = (b, id(cs.environment), params.tobytes())
        if key in keys:
            world_model[k] = keys[key]
            continue
        if b not in bases:
            compiled = CompiledCubesat(
                cs.spec,
                bare_model=cs.model,
                environment=cs.environment,
                disturbances=cs.disturbances,
                controller=ctl,
                bus_qpos=cs.idx.q_pos.start,
                bus_dof=cs.idx.v_lin.start,
                timing=timing,
            )
            bases[b] = compiled
            model = compiled.model
        else:
            model = copy.copy(bases[b].model)
            p_at, t_at = _numeric_slice(model, PARAMS_NUMERIC), _numeric_slice(model, TABLE_NUMERIC)
            if p_at.stop - p_at.start != len(params) or t_at.stop - t_at.start != len(table):
                raise ConfigError(
                    [
                        f"world {k}: sim.loads: the compiled loads' parameter block and table hold "
                        f"{len(params)} and {len(table)} numbers, world {int(np.flatnonzero(bare_index == b)[0])}'s "
                        f"model {p_at.stop - p_at.start} and {t_at.stop - t_at.start}; one batch needs one size"
                    ]
                )
            model.numeric_data[p_at] = params
            model.numeric_data[t_at] = table
        keys[key] = len(models)
        world_model[k] = len(models)
        models.append(model)
    return models, world_model


class CompiledCubesatWorlds:
    """The cubesat of N worlds with compiled loads (module docstring).

    Args:
      models: each world's model (the batch's caller models: ``models[k]`` runs world k).
      environments: the worlds' environments.
      controller: the worlds' B-dot controller.
      timestep_s: δt [s].

    The runner calls :meth:`attach` with its batch, :meth:`control` at the steps where
    ``step % control_every == 0`` and :meth:`probes` at the records; it never calls
    :meth:`loads` (``native_steps``).
    """

    probe_names = PROBES
    native_steps = True

    def __init__(
        self,
        *,
        models: Sequence[mujoco.MjModel],
        environments: EnvironmentStack,
        controller: BdotWorlds,
        timestep_s: float,
    ) -> None:
        self.models = list(models)
        self.n = controller.n
        if len(self.models) != self.n:
            raise ValueError(f"models: {len(self.models)} models for {self.n} worlds")
        self.env = environments
        self.ctl = controller
        if controller.environments is None:
            controller.environments = environments  # the non-monotonic law reads the field table ahead
        self.dt = float(timestep_s)
        self.control_every = math.gcd(controller.n_att, controller.n_cycle)
        m0 = self.models[0]
        self.state_adr = int(m0.plugin_stateadr[0])
        p_at, t_at = _numeric_slice(m0, PARAMS_NUMERIC), _numeric_slice(m0, TABLE_NUMERIC)
        self._adr = (p_at.start, t_at.start)
        fn = ctypes.CDLL(str(load_plugin(LIBRARY))).magsail_cubesat_probe_rows
        fn.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int]
        fn.argtypes += [ctypes.c_void_p] * 4 + [ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p]
        fn.restype = ctypes.c_int
        self._probe_rows = fn
        self._addresses = np.array([m._address for m in self.models], dtype=np.uintp)
        self.live = np.ones(self.n, dtype=bool)
        self._rows: dict[str, np.ndarray] = {}
        self.reset()

    def attach(self, batch: Any) -> None:
        """Bind the batch's state rows this plant reads and writes (``time``, ``qpos``, ``qvel``,
        ``plugin_state``: views of the rows, one row stride)."""
        rows = {name: batch.bind(name) for name in ("time", "qpos", "qvel", "plugin_state")}
        strides = {a.strides[0] for a in rows.values()}
        if len(strides) != 1 or any(a.ndim > 1 and a.strides[1] != a.itemsize for a in rows.values()):
            raise ValueError("batch: its state fields are not rows of one stride")  # pragma: no cover
        self._rows = rows
        self._stride = strides.pop() // rows["qpos"].itemsize

    def reset(self) -> None:
        """The controller state of the build (the plugin's state is in the batch's state rows)."""
        self.ctl.reset()

    def set_live(self, live: np.ndarray) -> None:
        """Which worlds still run (the others keep their state)."""
        self.live = live
        self.ctl.live = live

    def control(self, step: int, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray) -> None:
        """The controller samples due at step ``step`` and each live world's held dipole and wheel
        command into its plugin state (the next evaluation is the step's first)."""
        env = self.env.sample(step * self.dt)
        c = self.ctl
        c.sample(step, qpos, qvel, env)
        ps, a = self._rows["plugin_state"], self.state_adr
        rows: Any = slice(None) if self.live.all() else np.flatnonzero(self.live)
        d0, w0 = a + _S["DIPOLE"], a + _S["WHEEL_CMD"]
        ps[rows, d0 : d0 + 3] = c.dipole_held[rows]
        ps[rows, w0 : w0 + 3] = c.wheel_cmd[rows]
        ps[rows, a + _S["STALE"]] = 1.0

    def control_failures(self) -> dict[int, str]:
        """The worlds whose plug-in detumble law raised at the last :meth:`control` → message
        (taken: the next call starts empty)."""
        errors, self.ctl.law_errors = self.ctl.law_errors, {}
        return errors

    def plugin_values(self) -> np.ndarray:
        """(N, 18) what the plugin computes at each live world's state and step (the single run's
        :meth:`~magsail_mj.concepts.cnusail.compiled.CompiledCubesat.probe`): gravity gradient, drag,
        SRP, residual dipole and magnetorquer torques [N m, body axes], then the wheel motor torques
        [N m]; zeros for a stopped world."""
        out = np.zeros((self.n, 18))
        r = self._rows
        skip = (~self.live).astype(np.uint8)
        status = self._probe_rows(
            self.n,
            self._addresses.ctypes.data,
            self._adr[0],
            self._adr[1],
            self.state_adr,
            r["time"].ctypes.data,
            r["qpos"].ctypes.data,
            r["qvel"].ctypes.data,
            r["plugin_state"].ctypes.data,
            self._stride,
            skip.ctypes.data,
            out.ctypes.data,
        )
        if status != 0:
            raise ValueError(f"models[{-1 - status}]: its numerics are not the cubesat loads' parameter block")
        return out

    def probes(self, step: int, qpos: np.ndarray, qvel: np.ndarray) -> dict[str, np.ndarray]:
        """The probes' values at step ``step`` (after :meth:`control` when it was due), (N, …) each."""
        c = self.ctl
        v = self.plugin_values()
        return {
            **controller_probes(c, qpos, qvel),
            "T_M_Nm": v[:, 15:18],
            "torque_dist_body_Nm": v[:, :12].reshape(self.n, 4, 3),
            "torque_mtq_body_Nm": v[:, 12:15],
        }

    def loads(self, step: int, qpos: np.ndarray, qvel: np.ndarray, xfrc: np.ndarray) -> None:
        """Never called: the loads are computed inside MuJoCo's step."""
        raise RuntimeError("loads: compiled loads are computed inside MuJoCo's step (native_steps)")

    def get_state(self) -> dict[str, Any]:
        """The Python-side state as plain data: the controller's."""
        return {"controller": self.ctl.get_state()}

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a state of :meth:`get_state`."""
        self.ctl.set_state(state["controller"])
