r"""CNUSAIL's part of a batch of worlds (found by :mod:`magsail_mj.batch` through the concept registry).

What a batch runs of this concept: the attitude scenarios with the stand-alone B-dot detumble law
(``control.mode = "bdot"``; S1 ``detumble_pre``, S2 ``detumble_post`` and their Monte Carlo), each
world with its own initial state, epoch and orbit, environment models, B-dot gain and form,
magnetorquer and wheel limits, masses, inertias and geometry that keep the model's sizes, and
disturbance parameters, with its loads vectorised in NumPy or compiled (``sim.loads = "compiled"``:
the MuJoCo plugin inside each world's step, each world on a model of its own numbers,
:mod:`~magsail_mj.concepts.cnusail.batch_compiled`). What it refuses, naming the key
(:func:`refusals`, :data:`LOCKSTEP_KEYS`): the pointing laws (``eigen_axis``, ``pd``: they run one
at a time), sensor noise, the sub-stepped armature model, and keys that must be shared by every
world (the controller's schedule, the drag facet layout, the environment grid).

:class:`CnusailWorlds` builds every world as its single run does (:class:`CnusailModel`'s parts:
the MJCF parameters and compiled model, the environment, the disturbance load, the initial state),
with two caches: worlds whose MJCF parameters are equal share one compiled model, and worlds whose
environment tables and duration are equal share one
:class:`~magsail_mj.environment.environment.Environment` (its orbit, IGRF and Sun tables are the
expensive part of a build, ≈ 0.3–0.9 s for three orbits). Its :meth:`~CnusailWorlds.plant` is the
cubesat over the world axis (:class:`~magsail_mj.concepts.cnusail.batch_plant.CubesatWorlds`), and
:meth:`~CnusailWorlds.scenario` world k's task for its run folder.
"""

from __future__ import annotations

import json
from typing import Sequence

import mujoco
import numpy as np

from magsail_mj.batch.environment import EnvironmentStack
from magsail_mj.batch.worlds import atmosphere_mix_problems
from magsail_mj.batch.runner import HoldBelowWorlds
from magsail_mj.concepts.cnusail.batch_compiled import CompiledCubesatWorlds, world_models
from magsail_mj.concepts.cnusail.batch_control import BdotWorlds
from magsail_mj.concepts.cnusail.batch_loads import DisturbanceWorlds
from magsail_mj.concepts.cnusail.batch_plant import CubesatWorlds
from magsail_mj.concepts.cnusail.config import CnusailConfig
from magsail_mj.concepts.cnusail.mjcf import build_cubesat_spec, cubesat_indices
from magsail_mj.concepts.cnusail.model import CnusailModel, model_params
from magsail_mj.concepts.cnusail.tasks import AttitudeTask, stop_rule_of
from magsail_mj.environment.environment import Environment

__all__ = [
    "LOCKSTEP_KEYS",
    "COMPILED_LOADS",
    "refusals",
    "build_worlds",
    "compile_model",
    "CnusailWorlds",
    "world_cubesat",
]

COMPILED_LOADS = True
"""The batch runs this concept's worlds with ``sim.loads = "compiled"`` too
(:mod:`~magsail_mj.concepts.cnusail.batch_compiled`)."""

LOCKSTEP_KEYS: dict[str, str] = {
    "control.mode": "the batch runs one control law",
    "control.rate_Hz": "the batch samples every world's attitude law on one schedule",
    "actuators.mtq.cycle_s": "the batch samples every world's magnetorquers on one schedule",
    "actuators.mtq.blank_s": "the batch blanks every world's magnetorquers on one schedule",
    "spacecraft.drag_surfaces": "the drag facets of all worlds are one array (one facet count)",
    "field.sample_step_s": "the environments of all worlds share one time grid",
}
"""Keys of this concept that must be the same in every world of a batch, with the reason."""


def refusals(cfgs: Sequence[CnusailConfig]) -> list[str]:
    """What the batch does not run in these worlds (module docstring): problem lines naming the
    world, the key path and the value."""
    out = []
    for k, cfg in enumerate(cfgs):
        where = f"world {k}: "
        if cfg.kind != "attitude":
            out.append(f"{where}kind: the batch runs attitude runs only, got {cfg.kind!r}")
            continue
        c = cfg.control
        if c.mode != "bdot":
            out.append(
                f"{where}control.mode: the batch runs the B-dot detumble law ('bdot') only; 'eigen_axis' and "
                f"'pd' runs go one at a time (magsail_mj.load without worlds), got {c.mode!r}"
            )
        for key in ("magnetometer_noise_T", "gyro_noise_rad_s"):
            value = getattr(c.sensors, key)
            if value > 0:
                out.append(
                    f"{where}control.sensors.{key}: sensor noise is not run in a batch (its random draws are per "
                    f"world); must be 0, got {value!r}"
                )
        if cfg.actuators.wheels.electrical != "quasi_static":
            out.append(
                f"{where}actuators.wheels.electrical: the batch runs the quasi-static armature only, "
                f"got {cfg.actuators.wheels.electrical!r}"
            )
        out += atmosphere_mix_problems(cfgs[0], cfg, where=where) if k else []
    return out


class _Cache:
    """Compiled models by MJCF parameters and environments by tables and duration, in order of
    first use."""

    def __init__(self) -> None:
        self.models: list[tuple[mujoco.MjSpec, mujoco.MjModel]] = []
        self.environments: list[Environment] = []
        self._models: dict[str, int] = {}
        self._envs: dict[str, int] = {}

    def model_index(self, cfg: CnusailConfig) -> int:
        key = repr(model_params(cfg))
        if key not in self._models:
            spec = build_cubesat_spec(model_params(cfg))
            self._models[key] = len(self.models)
            self.models.append((spec, spec.compile()))
        return self._models[key]

    def environment_index(self, cfg: CnusailConfig) -> int:
        env_cfg = cfg.environment_config()
        key = json.dumps([env_cfg.model_dump(mode="json"), cfg.sim.duration_s], sort_keys=True)
        if key not in self._envs:
            self._envs[key] = len(self.environments)
            self.environments.append(Environment.from_config(env_cfg, duration_s=cfg.sim.duration_s))
        return self._envs[key]


def world_cubesat(
    cfg: CnusailConfig, *, spec: mujoco.MjSpec, model: mujoco.MjModel, environment: Environment
) -> CnusailModel:
    """The built cubesat of ``cfg`` from a compiled ``model`` (of ``spec``) and an ``environment``
    shared with other worlds: a :class:`CnusailModel` holding what its own construction makes
    (``tests/test_batch_build.py`` checks that the attributes are the same)."""
    cs = object.__new__(CnusailModel)
    cs.cfg = cfg
    cs.params = model_params(cfg)
    cs.spec, cs.model = spec, model
    cs.idx = cubesat_indices(model)
    cs.environment = environment
    cs.orbit_period_s = environment.elements.period(environment.mu)
    cs.inertia = np.diag(np.asarray(cfg.spacecraft.inertia, dtype=float))
    cs.disturbances = cs.make_disturbances()
    return cs


class CnusailWorlds:
    """The CNUSAIL worlds of a batch (module docstring).

    Attributes:
      cfgs: each world's config; cubesats: each world's built cubesat.
      models: the distinct compiled models (``models[0]`` is world 0's); world_model: (N,) index of
        each world's model in it. With ``sim.loads = "compiled"`` these are the models with the
        plugin, one per distinct MJCF, environment and parameter block
        (:func:`~magsail_mj.concepts.cnusail.batch_compiled.world_models`), and ``caller_models`` is
        true: the batch runs each world on its own model (:meth:`mujoco.batch.Batch.set_models`)
        instead of expanding fields.
      bare_model: world 0's model without the plugin (the bare ``mj_step`` a benchmark compares with).
      environments: the distinct environments; world_env: (N,) index of each world's.
    """

    def __init__(self, cfgs: Sequence[CnusailConfig]) -> None:
        cache = _Cache()
        self.cfgs = list(cfgs)
        self.cubesats: list[CnusailModel] = []
        world_model, world_env = [], []
        for cfg in self.cfgs:
            m_i, e_i = cache.model_index(cfg), cache.environment_index(cfg)
            spec, model = cache.models[m_i]
            self.cubesats.append(world_cubesat(cfg, spec=spec, model=model, environment=cache.environments[e_i]))
            world_model.append(m_i)
            world_env.append(e_i)
        self.models = [m for _, m in cache.models]
        self.environments = cache.environments
        self.world_model = np.array(world_model, dtype=np.intp)
        self.world_env = np.array(world_env, dtype=np.intp)
        self.bare_model = self.models[0]
        self.caller_models = self.cfgs[0].sim.loads == "compiled"
        if self.caller_models:
            self.models, self.world_model = world_models(
                self.cubesats, self.world_model, timing=self.cfgs[0].sim.load_timing
            )

    @staticmethod
    def compile_model(cfg: CnusailConfig) -> mujoco.MjModel:
        """The compiled model of ``cfg`` alone (to find the keys that change the sizes)."""
        return build_cubesat_spec(model_params(cfg)).compile()

    def init_state(self, world: int, data: mujoco.MjData) -> None:
        """Write world ``world``'s initial state into ``data`` (an ``MjData`` of its model), as its
        single run does."""
        self.cubesats[world].init_state(data)

    def plant(self) -> CubesatWorlds | CompiledCubesatWorlds:
        """The cubesat of every world over the world axis (each world's controller, disturbance
        load and environment; with compiled loads the controller and each world's model)."""
        cfg0 = self.cfgs[0]
        if self.caller_models:
            return CompiledCubesatWorlds(
                models=[self.models[int(j)] for j in self.world_model],
                environments=EnvironmentStack(self.environments, self.world_env),
                controller=BdotWorlds([cs.make_controller() for cs in self.cubesats]),
                timestep_s=cfg0.sim.timestep_s,
            )
        return CubesatWorlds(
            idx=self.cubesats[0].idx,
            environments=EnvironmentStack(self.environments, self.world_env),
            disturbances=DisturbanceWorlds([cs.disturbances for cs in self.cubesats]),
            controller=BdotWorlds([cs.make_controller() for cs in self.cubesats]),
            timestep_s=cfg0.sim.timestep_s,
            load_timing=cfg0.sim.load_timing,
            nv=self.models[0].nv,
        )

    def stop_rule(self) -> HoldBelowWorlds | None:
        """Each world's detumble stop rule (``sim.stop_rate_deg_s``, ``sim.stop_hold_s``; the single
        run's :func:`~magsail_mj.concepts.cnusail.tasks.stop_rule_of`) over the world axis; ``None``
        when no world has one."""
        rules = [stop_rule_of(cs.cfg, cs.idx.v_ang) for cs in self.cubesats]
        if all(r is None for r in rules):
            return None
        return HoldBelowWorlds(
            probe="qvel",
            index=self.cubesats[0].idx.v_ang,
            thresholds=np.array([-np.inf if r is None else r.threshold for r in rules]),
            holds_s=np.array([0.0 if r is None else r.hold_s for r in rules]),
            tolerance_s=1e-6 * self.cfgs[0].sim.timestep_s,
            describe=["" if r is None else r.describe for r in rules],
        )

    def scenario(self, world: int) -> AttitudeTask:
        """World ``world``'s task (post-processing, plots, manifest) as its single run has it after
        running: its built cubesat and a controller of its config (the B-dot controller's events
        stay empty, as in a single B-dot run)."""
        cs = self.cubesats[world]
        task = object.__new__(AttitudeTask)
        task.cfg = cs.cfg
        task.cubesat = cs
        task.params, task.spec, task.model, task.idx = cs.params, cs.spec, cs.model, cs.idx
        task.environment, task.orbit_period_s = cs.environment, cs.orbit_period_s
        task.inertia, task.disturbances = cs.inertia, cs.disturbances
        task.controller = cs.make_controller()
        return task


def build_worlds(cfgs: Sequence[CnusailConfig]) -> CnusailWorlds:
    """Every world of a batch of CNUSAIL configs (already checked by :func:`refusals`)."""
    return CnusailWorlds(cfgs)


def compile_model(cfg: CnusailConfig) -> mujoco.MjModel:
    """The compiled model of ``cfg`` alone (≈ 1 ms): its sizes tell which configs may share a
    batch (:func:`magsail_mj.batch.groups.world_key`)."""
    return CnusailWorlds.compile_model(cfg)
