r"""The CNUSAIL cubesat's loads compiled into its model (``sim.loads = "compiled"``).

The loads of a run (:class:`~magsail_mj.concepts.cnusail.disturbances.CubesatDisturbanceLoad`:
gravity gradient, drag, SRP on the sail, residual dipole, Yoo et al. 2016, Eqs. 12–23;
:class:`~magsail_mj.loads.actuators_cubesat.MagnetorquerLoad`, Eq. 5) and the per-step part of
the flight controller (magnetorquer blanking, the wheel driver's quasi-static DC motor, Eqs. 8–11)
are computed by the MuJoCo plugin ``magsail.cubesat_loads`` (``magsail_mj/compiled/cubesat_loads.c``,
its equations and frames in its header comment) inside ``mj_step``. This module

* builds the plugin's data: a copy of the cubesat's MjSpec with two custom numerics — the
  parameter block (:data:`PARAM_FIELDS`, read from the run's own load and controller objects, so
  both paths use the very same numbers) and the environment's coefficient table (the
  :class:`~magsail_mj.environment.interp.CubicTable` of the
  :class:`~magsail_mj.environment.environment.Environment`, ``(K, 4, nch)`` flattened) — and the
  plugin instance naming them (:class:`CompiledCubesat`); the scenario's own spec stays without
  the plugin, so its ``model.xml`` loads anywhere;
* runs the flight controller at its samples only (:class:`CompiledControl`): the attitude and
  magnetorquer samples are the Python controller's, and the held dipole and wheel command go to
  the plugin's state (:data:`STATE_FIELDS`).

Timing (``sim.load_timing``): ``"start"`` and ``"midpoint"`` are the Python path's (loads held over
the step, evaluated at the step's start or its predicted middle), equal to it to round-off;
``"stage"`` evaluates the loads at every RK4 stage (fourth order).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import mujoco
import numpy as np

from magsail_mj.compiled import load_plugin
from magsail_mj.compiled.plugin import PARAM_HEAD, TIMINGS, CompiledPlant, field_offsets, param_block
from magsail_mj.compiled.plugin import plugin_model, probe_function
from magsail_mj.concepts.cnusail.disturbances import CubesatDisturbanceLoad
from magsail_mj.concepts.cnusail.modes import CnusailController
from magsail_mj.config import ConfigError
from magsail_mj.environment.atmosphere import EXPONENTIAL_TABLE
from magsail_mj.environment.constants import AU
from magsail_mj.environment.environment import Environment
from magsail_mj.loads.base import StepState

__all__ = [
    "PARAM_FIELDS",
    "STATE_FIELDS",
    "STATE_OFFSETS",
    "LAYOUT_VERSION",
    "TIMINGS",
    "MAX_FACETS",
    "CompiledCubesat",
    "CompiledControl",
    "cubesat_params",
]

PLUGIN = "magsail.cubesat_loads"
LIBRARY = "cubesat_loads"
LAYOUT_VERSION = 1
MAX_FACETS = 8

PARAM_FIELDS: tuple[tuple[str, int], ...] = (
    *PARAM_HEAD,
    ("T0", 1),
    ("H", 1),
    ("K", 1),
    ("NCH", 1),
    ("R_E", 1),
    ("HAS_SUN", 1),
    ("SHADOW", 1),
    ("P0", 1),
    ("SCALE_DISTANCE", 1),
    ("ATMOSPHERE", 1),
    ("COROTATING", 1),
    ("OMEGA_EARTH", 1),
    ("AU", 1),
    ("GG", 1),
    ("MU", 1),
    ("J", 9),
    ("HAS_DIPOLE", 1),
    ("D", 3),
    ("NFACET", 1),
    ("HAS_SAIL", 1),
    ("SAIL_CENTRE", 3),
    ("SAIL_AREA", 1),
    ("OPT_R", 1),
    ("OPT_S", 1),
    ("B_F", 1),
    ("B_B", 1),
    ("E_F", 1),
    ("E_B", 1),
    ("SWAP_BACK", 1),
    ("N_CYCLE", 1),
    ("N_ON", 1),
    ("WHEEL_MODEL", 1),
    ("R_M", 1),
    ("K_BEMF", 1),
    ("K_M", 1),
    ("K_FRICTION", 1),
    ("V_MAX", 1),
    ("W_MAX", 1),
    ("WHEEL_DOF", 3),
    ("WHEEL_ACT", 3),
    ("NEXP", 1),
    ("FACETS", 7 * MAX_FACETS),
)
"""The parameter block, in the order of the C source's ``P_*`` enum (name, length), starting with
the common head (:data:`~magsail_mj.compiled.plugin.PARAM_HEAD`); then ``NEXP``
rows of the exponential atmosphere ``(h0 [km], h0 [m], ρ0 [kg/m³], H [m])``. Units SI; flags 0/1;
``J`` row-major [kg m²]; facet rows ``(n̂ (3), k = −½ C_d A c (3) [m³], two-sided)``, body axes."""

STATE_FIELDS: tuple[tuple[str, int], ...] = (
    ("STALE", 1),
    ("STEP", 1),
    ("DIPOLE", 3),
    ("WHEEL_CMD", 3),
    ("T_M", 3),
    ("TORQUE", 3),
    ("WORLD", 3),
    ("SOURCES", 15),
    ("MID_STEP", 1),
    ("PRIMED", 1),
)
"""The plugin state, in the order of the C source's ``S_*`` enum; then ``2 nv`` velocities (the
previous and the current step's start ``qvel``, for the midpoint prediction)."""


_S = field_offsets(STATE_FIELDS)
STATE_OFFSETS: dict[str, int] = dict(_S)
"""Each field of :data:`STATE_FIELDS` at its offset from the instance's plugin state address."""

_WHEEL_MODELS = {("dc_motor", "quasi_static"): 1, ("ideal", "quasi_static"): 2, ("ideal", "substep"): 2}
_ATMOSPHERES = {"exponential": 1, "msis": 2}


def cubesat_params(
    *,
    environment: Environment,
    disturbances: CubesatDisturbanceLoad,
    controller: CnusailController,
    body: int,
    qpos_adr: int,
    dof_adr: int,
    timing: str,
) -> np.ndarray:
    """The plugin's parameter block (:data:`PARAM_FIELDS`) from the run's own objects.

    Raises:
      ValueError: a wheel driver the plugin does not model (``actuators.wheels.electrical =
        "substep"`` of a DC motor), too many drag facets, or an unknown ``timing``.
    """
    p, put = param_block(
        PARAM_FIELDS, version=LAYOUT_VERSION, body=body, qpos_adr=qpos_adr, dof_adr=dof_adr, timing=timing
    )
    driver = controller.driver
    wheel_model = _WHEEL_MODELS.get((driver.model, driver.electrical))
    if wheel_model is None:
        raise ValueError(
            "actuators.wheels.electrical: compiled loads model the quasi-static DC motor (L → 0); "
            f"got {driver.electrical!r} for {driver.model!r} wheels (use sim.loads = 'python')"
        )
    drag = disturbances._drag or ()
    if len(drag) > MAX_FACETS:
        raise ValueError(f"disturbances: compiled loads take at most {MAX_FACETS} drag facets, got {len(drag)}")
    table = environment._table
    put("T0", table.t0)
    put("H", table.h)
    put("K", table.K)
    put("NCH", table.nch)
    put("R_E", environment.R_E)
    put("HAS_SUN", environment._has_sun)
    put("SHADOW", environment._shadow)
    put("P0", float(environment._P))
    put("SCALE_DISTANCE", bool(environment._scale_distance))
    put("ATMOSPHERE", _ATMOSPHERES.get(environment._atmo, 0))
    put("COROTATING", bool(environment._corot))
    put("OMEGA_EARTH", float(environment.omega_earth))
    put("AU", AU)
    put("GG", disturbances.gravity_gradient)
    put("MU", disturbances.mu)
    put("J", disturbances._J)
    put("HAS_DIPOLE", disturbances._D is not None)
    put("D", disturbances._D or (0.0, 0.0, 0.0))
    put("NFACET", len(drag))
    if drag:
        rows = np.zeros((MAX_FACETS, 7))
        rows[: len(drag)] = np.array(drag, dtype=float)
        put("FACETS", rows)
    sail = disturbances._sail
    put("HAS_SAIL", sail is not None)
    if sail is not None:
        o = sail.optics[0]
        put("SAIL_CENTRE", disturbances._sail_centre)
        put("SAIL_AREA", float(sail.area[0]))
        for name, value in (("OPT_R", o.r), ("OPT_S", o.s), ("B_F", o.B_f), ("B_B", o.B_b), ("E_F", o.e_f)):
            put(name, value)
        put("E_B", o.e_b)
        put("SWAP_BACK", bool(o.swap_back))
    put("N_CYCLE", controller._n_cycle)
    put("N_ON", controller._n_on)
    m = driver.p
    put("WHEEL_MODEL", wheel_model)
    put("R_M", m.R_ohm)
    put("K_BEMF", m.K_b_Vs_rad)
    put("K_M", m.K_M_Nm_A)
    put("K_FRICTION", m.K_B_Nms)
    put("V_MAX", m.V_max_V)
    put("W_MAX", m.speed_max_rad_s)
    put("WHEEL_DOF", controller.wheel_qvel)
    put("WHEEL_ACT", controller.wheel_act)
    put("NEXP", len(EXPONENTIAL_TABLE))
    rows = [(float(h0), float(h0) * 1e3, float(r0), float(H) * 1e3) for h0, r0, H in EXPONENTIAL_TABLE]
    return np.concatenate([p, np.array(rows, dtype=float).ravel()])


class CompiledCubesat(CompiledPlant):
    """The cubesat's model with the compiled loads (module docstring).

    Args:
      spec: the cubesat's MjSpec (copied; the copy gets the plugin and its numerics).
      environment, disturbances, controller: the run's objects (their numbers go to the plugin).
      bus_qpos, bus_dof: the bus free joint's first ``qpos`` and ``qvel`` addresses.
      timing: ``"start"``, ``"midpoint"`` or ``"stage"`` (``sim.load_timing``).

    Attributes:
      model: the compiled model with the plugin; ``bare_model``: the same without it (the bare
        ``mj_step`` a benchmark compares with).

    Raises:
      CompiledLoadsError: the plugin library cannot be built or loaded (no compiler).
      ConfigError: what the plugin does not model (a DC motor's ``actuators.wheels.electrical =
        "substep"``), named.
    """

    state_fields = STATE_FIELDS

    def __init__(
        self,
        spec: mujoco.MjSpec,
        *,
        bare_model: mujoco.MjModel,
        environment: Environment,
        disturbances: CubesatDisturbanceLoad,
        controller: CnusailController,
        bus_qpos: int,
        bus_dof: int,
        timing: str,
    ) -> None:
        probe = probe_function(load_plugin(LIBRARY), "magsail_cubesat_probe")
        self._probe = SimpleNamespace(fn=probe)  # a C function: not part of the walked state
        try:
            params = cubesat_params(
                environment=environment,
                disturbances=disturbances,
                controller=controller,
                body=disturbances.body_id,
                qpos_adr=bus_qpos,
                dof_adr=bus_dof,
                timing=timing,
            )
        except ValueError as err:
            raise ConfigError([str(err)]) from None
        model = plugin_model(
            spec,
            plugin=PLUGIN,
            instance="magsail_cubesat_loads",
            numerics={
                "params": ("magsail_cubesat_params", params),
                "table": ("magsail_cubesat_table", environment._table.coef.ravel()),
            },
        )
        super().__init__(model, bare_model=bare_model, timing=timing)

    def probe(self, data: mujoco.MjData) -> np.ndarray:
        """(18,) what the plugin computes at ``data``'s state and step (``magsail_cubesat_probe`` of
        the C source): the body-axes torques [N m] of gravity gradient, drag, SRP, residual dipole
        and the magnetorquers (rows of 3, the step's effective dipole) and the wheel motor torques
        [N m] the step applies — the records' ``torque_dist_body_Nm``, ``torque_mtq_body_Nm`` and
        ``T_M_Nm``."""
        out = np.empty(18)
        if self._probe.fn(self.model._address, data._address, 0, out.ctypes.data) != 0:
            raise ValueError("data: its model has no initialised cubesat-loads plugin")
        return out

    def write_command(self, data: mujoco.MjData, *, dipole_Am2: np.ndarray, wheel_cmd: np.ndarray) -> None:
        """Hold the dipole [A m², body axes] and the wheel command (current [A], or torque [N m] for
        ideal wheels) from the next evaluation on; the plugin's next evaluation is the step's first
        again (a re-evaluation within a step keeps its midpoint memory)."""
        ps, a = data.plugin_state, self.state_adr
        ps[a + _S["DIPOLE"] : a + _S["DIPOLE"] + 3] = dipole_Am2
        ps[a + _S["WHEEL_CMD"] : a + _S["WHEEL_CMD"] + 3] = wheel_cmd
        ps[a + _S["STALE"]] = 1.0


class CompiledCommand:
    """The held command of :class:`CompiledControl` (``apply_ctrl`` runs its samples)."""

    def __init__(self, control: "CompiledControl") -> None:
        self.of = SimpleNamespace(control=control)  # not walked by the checkpoint: the control is the run's
        self.state: Any = None

    def apply_ctrl(self, data: mujoco.MjData) -> None:
        self.of.control.sample(self.state, data)


class CompiledControl:
    """The flight controller at its samples, for compiled loads: due every ``gcd(n_att, n_cycle)``
    steps (the attitude period and the magnetorquer cycle in steps), it runs the controller's
    attitude and magnetorquer samples that fall on the step (:meth:`CnusailController._samples`)
    and writes the held dipole and wheel command into the plugin's state; blanking and the wheel
    driver's per-step part run in the plugin (module docstring)."""

    def __init__(self, controller: CnusailController, plant: CompiledCubesat) -> None:
        self.controller = controller
        self.of = SimpleNamespace(plant=plant)  # the plant holds the model: not part of the walked state
        self._dt = controller._dt
        self.period_s = math.gcd(controller.n_att, controller._n_cycle) * self._dt
        self.cmd = CompiledCommand(self)

    def update(self, state: StepState) -> CompiledCommand:
        self.cmd.state = state
        return self.cmd

    def sample(self, state: StepState, data: mujoco.MjData) -> None:
        """The controller's samples due at ``state`` and the held command into the plugin."""
        ctl = self.controller
        k = int(round(state.t / self._dt))
        i_att, i_mtq = k // ctl.n_att, k // ctl._n_cycle
        if i_att > ctl._last_att or i_mtq > ctl._last_mtq:
            ctl._samples(state, data, i_att, i_mtq)
        self.of.plant.write_command(data, dipole_Am2=ctl.dipole_held, wheel_cmd=ctl.wheel_cmd)
