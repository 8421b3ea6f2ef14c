r"""The flexible truss's part of a batch of worlds (found by :mod:`magsail_mj.batch` through the concept registry).

What a batch runs of this concept: the orbital rod-array scenarios (``scenario = "detumble"`` and
``"slew"``, :class:`~magsail_mj.concepts.truss_magnetorquer.tasks.OrbitalTrussTask`: the 800-node
lattice with tidal gravity, magnetorquer rods in the top-layer struts, and the B-dot, quaternion
feedback or open-loop law through the rod allocation), each world with its own initial rate,
attitude and node perturbation, epoch and orbit, field model, gains and law parameters, Lloyd
selection, rod dipoles, and masses, stiffness and damping that keep the model's sizes (each world's
compiled model, its fields expanded per world). What it refuses, naming the key (:func:`refusals`,
:data:`LOCKSTEP_KEYS`): the other scenarios, the mid-step load timing, the lattice's SRP and drag
loads, the J2 term of tidal gravity, the printed force pairs, and keys that must be shared by
every world (the law and its schedule, the environment grid).

:class:`TrussWorlds` builds every world as its single run does (its task's loads, controller and
probes, from :meth:`~magsail_mj.concepts.truss_magnetorquer.tasks.TrussScenario.simulation`'s
parts), with two caches: worlds whose structural keys are equal share one
:class:`~magsail_mj.concepts.truss_magnetorquer.model.TrussModel` and compiled model, and worlds
whose environment tables and duration are equal share one
:class:`~magsail_mj.environment.environment.Environment`. Its :meth:`~TrussWorlds.plant` is the
lattice over the world axis (:class:`~magsail_mj.concepts.truss_magnetorquer.batch_plant.LatticeWorlds`),
and :meth:`~TrussWorlds.scenario` world k's task for its run folder.
"""

from __future__ import annotations

import json
from typing import Sequence

import mujoco
import numpy as np

from magsail_mj.batch.environment import EnvironmentStack
from magsail_mj.batch.worlds import atmosphere_mix_problems
from magsail_mj.concepts import TASKS, discover
from magsail_mj.concepts.truss_magnetorquer.batch_control import RodControlWorlds
from magsail_mj.concepts.truss_magnetorquer.batch_loads import LatticeLoadWorlds
from magsail_mj.concepts.truss_magnetorquer.batch_plant import LatticeWorlds
from magsail_mj.concepts.truss_magnetorquer.config import TrussConfig
from magsail_mj.concepts.truss_magnetorquer.model import TrussModel, make_truss_model
from magsail_mj.concepts.truss_magnetorquer.tasks import OrbitalTrussTask
from magsail_mj.environment.environment import Environment
from magsail_mj.sim import BodyKinematics

__all__ = ["LOCKSTEP_KEYS", "refusals", "build_worlds", "compile_model", "TrussWorlds", "world_task", "MODEL_KEYS"]

LOCKSTEP_KEYS: dict[str, str] = {
    "control.kind": "the batch records one probe set (the quaternion feedback adds q_err)",
    "control.period_s": "the batch samples every world's rod controller on one schedule",
    "field.sample_step_s": "the environments of all worlds share one time grid",
}
"""Keys of this concept that must be the same in every world of a batch, with the reason."""

MODEL_KEYS = (
    "scenario",
    "lattice",
    "mass",
    "stiffness",
    "damping",
    "sim.timestep_s",
    "sim.integrator",
    "sim.solver_tolerance",
)
"""The keys :func:`~magsail_mj.concepts.truss_magnetorquer.model.make_truss_model` reads: worlds
equal in them share one model."""

_SCENARIOS = ("detumble", "slew")


def refusals(cfgs: Sequence[TrussConfig]) -> list[str]:
    """What the batch does not run in these worlds (module docstring): problem lines naming the
    world, the key path and the value."""
    out = []
    for k, cfg in enumerate(cfgs):
        where = f"world {k}: "
        if cfg.scenario not in _SCENARIOS:
            out.append(
                f"{where}scenario: the batch runs the truss's orbital scenarios {list(_SCENARIOS)} only, "
                f"got {cfg.scenario!r}"
            )
            continue
        if cfg.sim.load_timing != "start":
            out.append(
                f"{where}sim.load_timing: the truss batch holds the loads at the step's start ('start') only, "
                f"got {cfg.sim.load_timing!r}"
            )
        for table in ("srp", "drag"):
            if getattr(cfg, table).enabled:
                out.append(f"{where}{table}.enabled: the lattice's {table} load is not run in a batch; must be false")
        if cfg.gravity.j2:
            out.append(f"{where}gravity.j2: the J2 term of tidal gravity is not run in a batch; must be false")
        if cfg.actuators.force_pair != "corrected":
            out.append(
                f"{where}actuators.force_pair: the batch runs the corrected rod force pair only, "
                f"got {cfg.actuators.force_pair!r}"
            )
        if k and cfg.gravity.tidal != cfgs[0].gravity.tidal:
            out.append(
                f"{where}gravity.tidal: tidal gravity must be on in every world or in none; world 0 has "
                f"{cfgs[0].gravity.tidal!r}, got {cfg.gravity.tidal!r}"
            )
        out += atmosphere_mix_problems(cfgs[0], cfg, where=where) if k else []
    return out


def _model_key(cfg: TrussConfig) -> str:
    tree = cfg.model_dump(mode="json")
    picked = {}
    for key in MODEL_KEYS:
        node = tree
        for part in key.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        picked[key] = node
    return json.dumps(picked, sort_keys=True)


def world_task(
    cfg: TrussConfig, *, tm: TrussModel, model: mujoco.MjModel, environment: Environment
) -> OrbitalTrussTask:
    """The task of ``cfg`` on a truss model ``tm`` (compiled: ``model``) and an ``environment``
    shared with other worlds: what its own construction makes
    (:meth:`~magsail_mj.concepts.truss_magnetorquer.tasks.TrussScenario.__post_init__`;
    ``tests/test_batch_truss.py`` checks that the attributes are the same)."""
    discover()
    task = object.__new__(TASKS[(cfg.concept, cfg.scenario)])
    task.cfg, task.tm = cfg, tm
    task.spec, task.model = tm.spec, model
    task.torque_load = task.rod_load = task.tidal_load = task.controller = None
    task.environment = environment
    return task


class TrussWorlds:
    """The truss worlds of a batch (module docstring).

    Attributes:
      cfgs: each world's config; tasks: each world's task, with the loads, controller and probes
        its single run's :meth:`~magsail_mj.concepts.truss_magnetorquer.tasks.TrussScenario.simulation`
        builds (``loads``, ``controllers``, ``probes``: per world).
      models: the distinct compiled models (``models[0]`` is world 0's); world_model: (N,) index of
        each world's model in it.
      environments: the distinct environments; world_env: (N,) index of each world's.
    """

    def __init__(self, cfgs: Sequence[TrussConfig]) -> None:
        self.cfgs = list(cfgs)
        models: dict[str, int] = {}
        envs: dict[str, int] = {}
        built: list[tuple[TrussModel, mujoco.MjModel]] = []
        self.environments: list[Environment] = []
        self.tasks: list[OrbitalTrussTask] = []
        world_model, world_env = [], []
        for cfg in self.cfgs:
            key = _model_key(cfg)
            if key not in models:
                tm = make_truss_model(cfg)
                models[key] = len(built)
                built.append((tm, tm.spec.compile()))
            env_cfg = cfg.environment_config()
            env_key = json.dumps([env_cfg.model_dump(mode="json"), cfg.sim.duration_s], sort_keys=True)
            if env_key not in envs:
                envs[env_key] = len(self.environments)
                self.environments.append(Environment.from_config(env_cfg, duration_s=cfg.sim.duration_s))
            tm, model = built[models[key]]
            self.tasks.append(world_task(cfg, tm=tm, model=model, environment=self.environments[envs[env_key]]))
            world_model.append(models[key])
            world_env.append(envs[env_key])
        self.models = [m for _, m in built]
        self.world_model = np.array(world_model, dtype=np.intp)
        self.world_env = np.array(world_env, dtype=np.intp)
        self.loads = [task.loads() for task in self.tasks]
        self.controllers = [task.make_controller() for task in self.tasks]
        for task, ctl in zip(self.tasks, self.controllers):
            task.controller = ctl
        self.probes = [task.task_probes() for task in self.tasks]
        self.bare_model = self.models[0]

    @staticmethod
    def compile_model(cfg: TrussConfig) -> mujoco.MjModel:
        """The compiled model of ``cfg`` alone (to find the keys that change the sizes)."""
        return make_truss_model(cfg).spec.compile()

    def init_state(self, world: int, data: mujoco.MjData) -> None:
        """Write world ``world``'s initial state into ``data`` (an ``MjData`` of its model), as its
        single run does (the rigid motion of the initial rate and attitude, and any node
        perturbation)."""
        self.tasks[world].init_state(data)

    def plant(self) -> LatticeWorlds:
        """The lattice of every world over the world axis (each world's loads, controller, probes
        and strain check)."""
        cfg0, model0 = self.cfgs[0], self.models[0]
        kin = BodyKinematics(model0)
        if kin._part_block is None or kin.other.size or kin.free_body.size:
            raise ValueError("model: the truss batch needs a free lattice of particle bodies in one block")
        bodies, q_block, _, _ = kin._part_block
        pos0 = np.stack([self.models[int(j)].body_pos for j in self.world_model])
        return LatticeWorlds(
            pos0=pos0,
            particles=(bodies, q_block),
            environments=EnvironmentStack(self.environments, self.world_env),
            loads=LatticeLoadWorlds(
                [task.tidal_load for task in self.tasks], [task.rod_load for task in self.tasks], model0.nbody
            ),
            controller=RodControlWorlds(self.controllers, timestep_s=cfg0.sim.timestep_s),
            probes=self.probes,
            struts=self._struts(),
            inv_rest_length_sq=np.array([1.0 / task.tm.lattice.rest_length**2 for task in self.tasks]),
            max_strain=np.array([cfg.sim.max_strain for cfg in self.cfgs]),
            timestep_s=cfg0.sim.timestep_s,
        )

    def _struts(self) -> np.ndarray:
        """(S, 2) the struts' end bodies (node ``i`` is body ``i + 1``, as the single run's strain
        check reads them), the same in every world."""
        struts = self.tasks[0].tm.lattice.struts
        if any(not np.array_equal(task.tm.lattice.struts, struts) for task in self.tasks):
            raise ValueError("lattice: the worlds' lattices have different struts")
        return struts + 1

    def scenario(self, world: int) -> OrbitalTrussTask:
        """World ``world``'s task (post-processing, plots, manifest), with the loads and controller
        its single run's simulation builds."""
        return self.tasks[world]


def build_worlds(cfgs: Sequence[TrussConfig]) -> TrussWorlds:
    """Every world of a batch of truss configs (already checked by :func:`refusals`)."""
    return TrussWorlds(cfgs)


def compile_model(cfg: TrussConfig) -> mujoco.MjModel:
    """The compiled model of ``cfg`` alone (≈ 0.5 s for the 800-node lattice): its sizes tell which
    configs may share a batch (:func:`magsail_mj.batch.groups.world_key`)."""
    return TrussWorlds.compile_model(cfg)
