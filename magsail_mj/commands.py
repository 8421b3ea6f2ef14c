"""Typed controller commands and the helper that puts a controller and its actuators on a simulation.

A controller's ``update(state)`` returns one command of a small documented set; an *actuator*
(a load, see :mod:`magsail_mj.loads.base`) turns it into wrenches in ``xfrc_applied`` or into
MuJoCo ``ctrl`` values. A controller written against one command type runs on every spacecraft
that has an actuator for it (see :mod:`magsail_mj.loads.body_torque_actuators` for the
body-torque actuators of the truss, the cubesat and the reflector).

The command set (frozen dataclasses; every array field is a float or integer copy of what was
given, checked for shape and finiteness, a bad value raising ``ValueError`` that names the field;
the frame and the unit are in each field's name):

* :class:`BodyTorque` — ``torque_body_Nm`` (3,): body axes, N m;
* :class:`MagneticDipole` — ``dipole_body_Am2`` (3,): body axes, A m²;
* :class:`RodPolarities` — ``polarity`` (n_rods,) int8 in {−1, 0, +1}: per rod, along its own axis;
* :class:`LoopCurrents` — ``currents_A`` (n_loops,): per loop or coil path, A;
* :class:`WheelTorques` — ``torque_Nm`` (n_wheels,): motor torque on each rotor about its spin axis, N m;
* :class:`WheelVoltages` — ``voltage_V`` (n_wheels,): motor terminal voltage, V;
* :class:`JointTargets` — ``targets`` (n,) and ``actuator_ids`` (n,): MuJoCo actuator set points in
  the joints' units (m or rad), written to ``data.ctrl`` by its ``apply_ctrl``.

Existing controllers keep their own (richer) command objects, whose field names these follow
where they meet: the truss rod controllers' :class:`~magsail_mj.control.rod_attitude.RodCommand`
carries ``polarity`` (read by the rod load, so a :class:`RodPolarities` drives it too) and the
reflector B-dot command ``currents_A``; the cubesat magnetorquer load reads the CNUSAIL command's
``dipole_body`` or a :class:`MagneticDipole`'s ``dipole_body_Am2``.

:func:`attach` is the documented way to run a controller of this set on a loaded simulation::

    import magsail_mj
    from magsail_mj.commands import attach
    from magsail_mj.control.quaternion_feedback import QuaternionPD
    from magsail_mj.loads.body_torque_actuators import attitude_sensor, body_torque_actuator

    sim = magsail_mj.load("magsail_mj/concepts/cnusail/configs/nadir_post.toml", ["sim.duration_s=60"])
    pd = QuaternionPD(sensor=attitude_sensor(sim), q_ref_wxyz=(1, 0, 0, 0), Pq_Nm=(1e-3,) * 3,
                      Pw_Nms=(1e-2,) * 3, period_s=0.1)
    sim2 = attach(sim, pd, body_torque_actuator(sim))
    result = sim2.run()   # records: qpos, qvel, torque_request_body_Nm, torque_delivered_body_Nm, ...
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from magsail_mj.loads.actuators_cubesat import MagnetorquerLoad
from magsail_mj.loads.base import Load
from magsail_mj.loads.body_torque import HeldBodyTorqueLoad
from magsail_mj.loads.magnetorquer_rods import MagnetorquerRodLoad
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.sim import Controller, Simulation

__all__ = [
    "BodyTorque",
    "MagneticDipole",
    "RodPolarities",
    "LoopCurrents",
    "WheelTorques",
    "WheelVoltages",
    "JointTargets",
    "COMMAND_DRIVEN_LOADS",
    "KEPT_PROBES",
    "attach",
]


def _array(value: Any, name: str, *, size: int | None = None, dtype: type = float) -> np.ndarray:
    """A 1-D copy of ``value`` of ``size`` elements (any size ≥ 1 when ``None``), finite."""
    try:
        a = np.array(value, dtype=dtype, copy=True)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected {size or 'one or more'} numbers, got {value!r}") from None
    if a.ndim != 1 or a.size == 0 or (size is not None and a.size != size):
        raise ValueError(f"{name}: expected a 1-D array of {size or 'one or more'} numbers, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: every component must be finite, got {value!r}")
    return a


def _set(obj: Any, name: str, value: np.ndarray) -> None:
    object.__setattr__(obj, name, value)


@dataclass(frozen=True, eq=False)
class BodyTorque:
    """Request of a torque on the spacecraft, body axes [N m] (``torque_body_Nm``, (3,)).

    The body axes are the spacecraft's (the rigid body's frame, or the best-fit frame of a flexible
    lattice). What an actuator delivers may differ (limits, coils that cannot torque along the field).
    """

    torque_body_Nm: np.ndarray

    def __post_init__(self) -> None:
        _set(self, "torque_body_Nm", _array(self.torque_body_Nm, "torque_body_Nm", size=3))


@dataclass(frozen=True, eq=False)
class MagneticDipole:
    """Commanded magnetic dipole moment, body axes [A m²] (``dipole_body_Am2``, (3,)); the torque is
    ``m × B`` with the field in the same axes."""

    dipole_body_Am2: np.ndarray

    def __post_init__(self) -> None:
        _set(self, "dipole_body_Am2", _array(self.dipole_body_Am2, "dipole_body_Am2", size=3))


@dataclass(frozen=True, eq=False)
class RodPolarities:
    """Polarity of each magnetorquer rod, −1, 0 or +1 (``polarity``, (n_rods,) int8): rod ``k`` gives
    ``polarity[k] · m_rod`` along its own axis (as the truss rod load reads it)."""

    polarity: np.ndarray

    def __post_init__(self) -> None:
        a = _array(self.polarity, "polarity")
        if not np.all(np.isin(a, (-1.0, 0.0, 1.0))):
            raise ValueError(f"polarity: every rod polarity must be -1, 0 or +1, got {self.polarity!r}")
        _set(self, "polarity", a.astype(np.int8))


@dataclass(frozen=True, eq=False)
class LoopCurrents:
    """Current in each loop or coil path [A] (``currents_A``, (n_loops,)); the sign follows the
    loop's own positive circulation."""

    currents_A: np.ndarray

    def __post_init__(self) -> None:
        _set(self, "currents_A", _array(self.currents_A, "currents_A"))


@dataclass(frozen=True, eq=False)
class WheelTorques:
    """Motor torque on each reaction-wheel rotor about its spin axis [N m] (``torque_Nm``,
    (n_wheels,)); the bus receives the reaction (minus the bearing friction)."""

    torque_Nm: np.ndarray

    def __post_init__(self) -> None:
        _set(self, "torque_Nm", _array(self.torque_Nm, "torque_Nm"))


@dataclass(frozen=True, eq=False)
class WheelVoltages:
    """Terminal voltage of each wheel motor [V] (``voltage_V``, (n_wheels,))."""

    voltage_V: np.ndarray

    def __post_init__(self) -> None:
        _set(self, "voltage_V", _array(self.voltage_V, "voltage_V"))


@dataclass(frozen=True, eq=False)
class JointTargets:
    """Set points of MuJoCo actuators (``targets`` (n,) in the joints' units, m or rad) for the
    actuators ``actuator_ids`` (n,); :meth:`apply_ctrl` writes them to ``data.ctrl`` at each
    controller sample (the runner calls it)."""

    targets: np.ndarray
    actuator_ids: np.ndarray

    def __post_init__(self) -> None:
        t = _array(self.targets, "targets")
        ids = _array(self.actuator_ids, "actuator_ids", size=t.size)
        if np.any(ids < 0) or np.any(ids != np.round(ids)):
            raise ValueError(f"actuator_ids: expected {t.size} integer actuator ids >= 0, got {self.actuator_ids!r}")
        _set(self, "targets", t)
        _set(self, "actuator_ids", ids.astype(np.int64))

    def apply_ctrl(self, data: Any) -> None:
        """Write the targets into ``data.ctrl``."""
        data.ctrl[self.actuator_ids] = self.targets


COMMAND_DRIVEN_LOADS: tuple[type, ...] = (HeldBodyTorqueLoad, StrutTorqueLoad, MagnetorquerRodLoad, MagnetorquerLoad)
"""Load types that act on a scenario's own command (or its own torque profile): :func:`attach`
leaves them out by default, since the new controller's actuators replace them."""

KEPT_PROBES: tuple[str, ...] = ("qpos", "qvel")
"""Probes of the original simulation that :func:`attach` keeps by default (they read only the
MuJoCo state; the others read the original controller's command)."""


def _is_environment_load(load: Load) -> bool:
    return not isinstance(load, COMMAND_DRIVEN_LOADS)


def attach(
    sim: Simulation,
    controller: Controller,
    actuators: Load | Sequence[Load],
    *,
    keep_load: Callable[[Load], bool] = _is_environment_load,
    keep_probes: Sequence[str] = KEPT_PROBES,
) -> Simulation:
    """A new simulation of ``sim``'s spacecraft run by ``controller`` through ``actuators``.

    The new simulation shares ``sim``'s compiled model, initial state, environment, strain check,
    timing and record settings; its loads are ``sim``'s loads for which ``keep_load`` is true (by
    default all but :data:`COMMAND_DRIVEN_LOADS`: disturbances and environment stay) followed by
    ``actuators``; its probes are ``keep_probes`` of ``sim``'s followed by each actuator's
    ``probes()``. An actuator with a ``bind(data)`` method is given the new ``MjData`` (the wheel
    actuator writes ``data.ctrl``). ``scenario`` and ``cfg`` are carried over (the scenario's
    post-processing expects its own probes and does not apply); the checkpoint identity is the
    config's hash extended with the controller and actuator types, so a checkpoint of the plain
    config is refused and vice versa. ``sim`` itself is left as it was.

    Raises:
      TypeError: ``sim`` is not a stepped :class:`~magsail_mj.sim.Simulation`, the controller has no
        ``update``/``period_s``, or an actuator has no ``add``.
    """
    if not isinstance(sim, Simulation):
        raise TypeError(f"sim: expected a stepped magsail_mj.sim.Simulation, got {type(sim).__name__}")
    if not (callable(getattr(controller, "update", None)) and getattr(controller, "period_s", 0) > 0):
        raise TypeError(
            f"controller: expected an object with update(state) and period_s > 0, got {type(controller).__name__}"
        )
    acts = [actuators] if callable(getattr(actuators, "add", None)) else list(actuators)
    for a in acts:
        if not callable(getattr(a, "add", None)):
            raise TypeError(f"actuators: {type(a).__name__} has no add(state, xfrc)")
    probes = {name: sim.probes[name] for name in keep_probes if name in sim.probes}
    for a in acts:
        probes.update(a.probes() if callable(getattr(a, "probes", None)) else {})
    new = dataclasses.replace(sim, controller=controller, loads=[*filter(keep_load, sim.loads), *acts], probes=probes)
    for a in acts:
        if callable(getattr(a, "bind", None)):
            a.bind(new.data)
    for key in ("scenario", "cfg"):
        if hasattr(sim, key):
            setattr(new, key, getattr(sim, key))
    tag = "+".join(type(x).__qualname__ for x in (controller, *acts))
    new.identity = {**sim.identity, "numbers_hash": f"{sim.identity.get('numbers_hash')}|attach:{tag}"}
    return new
