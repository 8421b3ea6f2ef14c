r"""Body-torque actuators: one :class:`~magsail_mj.commands.BodyTorque` request, three spacecraft.

Each actuator is a load (:mod:`magsail_mj.loads.base`) that reads the held request
``state.ctrl.torque_body_Nm`` (body axes, N m; no command or another command type = zero request),
turns it into what its spacecraft can do, and keeps, for the step it last applied,
``requested_body_Nm`` and ``delivered_body_Nm`` (body axes, N m). Its :meth:`probes` record them
as ``torque_request_body_Nm`` and ``torque_delivered_body_Nm`` (the runner records before the
loads act, so a record at ``t`` holds the pair applied over the step that ended at ``t``; the
record at ``t = 0`` is zero).

* Truss, :class:`StrutBodyTorqueActuator` — force pairs across the top-layer x1- and y1-struts
  through the generic distributed torquer of Robb et al. 2022a, Sec. 2
  (:class:`~magsail_mj.loads.strut_torque.StrutTorqueLoad`: τ₁ over the y1-struts, τ₂ over the
  x1-struts, τ₃ over all of them about their normals). Delivered: the total couple of the pairs,
  ``Σ (r_j − r_i) × F_j``, in the best-fit body axes; it equals the request exactly on the
  undeformed lattice and within the deformation otherwise (each couple turns with its strut).
* Cubesat, :class:`WheelBodyTorqueActuator` — the three reaction wheels (spin axes = body x, y, z)
  through the existing :class:`~magsail_mj.loads.actuators_cubesat.WheelDriver` (current or torque
  command ``−u + K_B ω_M`` with its current/torque limit, voltage clip, speed limiter), written to
  ``data.ctrl`` every step. Delivered: ``−(T_M − K_B ω_M)``
  (:meth:`~magsail_mj.loads.actuators_cubesat.WheelDriver.body_torque`), i.e. the request clipped
  to ±τ_max per axis while no voltage or speed limit acts.
* Reflector, :class:`CoilBodyTorqueActuator` — the coil paths (x-coil, y-coil, in-plane loop) as
  a dipole ``m`` in body axes: the request is projected onto the plane ⊥ B and saturated by the
  reflector's own rule (:func:`~magsail_mj.control.reflector_pitch.project_and_saturate`:
  ``"norm"``, ``"field_scaled"`` or ``"per_path"``), the minimum-norm dipole
  ``m = B × T / |B|²`` is formed and the delivered torque is ``m × B`` — never along B, so the
  reflector delivers only the part of the request ⊥ B.

The attitude the body-torque laws see comes from :func:`attitude_sensor`: the rigid body's
quaternion and rate (cubesat bus, reflector plate) or the lattice's best fit with a
backward-difference rate (truss). :func:`body_torque_actuator` builds the
actuator of a loaded simulation's spacecraft (see :func:`magsail_mj.commands.attach`).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Literal, Sequence

import numpy as np

from magsail_mj.control.reflector_pitch import project_and_saturate
from magsail_mj.estimation.attitude import BestFitRotation, body_rate_step
from magsail_mj.lattice.geometry import Lattice
from magsail_mj.loads.actuators_cubesat import WheelDriver
from magsail_mj.loads.base import StepState
from magsail_mj.loads.strut_torque import StrutTorqueLoad
from magsail_mj.quaternion import quat_from_matrix, quat_to_matrix
from magsail_mj.vec3 import cross3, moment_sum

__all__ = [
    "requested_torque",
    "coil_torque",
    "RigidBodyAttitude",
    "LatticeAttitude",
    "StrutBodyTorqueActuator",
    "WheelBodyTorqueActuator",
    "CoilBodyTorqueActuator",
    "attitude_sensor",
    "body_torque_actuator",
]


def requested_torque(state: StepState) -> np.ndarray:
    """The held request ``state.ctrl.torque_body_Nm`` (3,) [N m], zero without a body-torque command."""
    T = getattr(state.ctrl, "torque_body_Nm", None)
    return np.zeros(3) if T is None else np.asarray(T, dtype=float)


def coil_torque(
    T_request_body: np.ndarray,
    B_body: np.ndarray,
    *,
    saturation: Literal["norm", "field_scaled", "per_path"],
    cap_Nm: float,
    B_ref_T: float,
    m_max_Am2: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(m, m × B, saturated)``: the coil dipole [A m²] and the torque it delivers [N m] for a request.

    The achievable torque is the request's component ⊥ B, saturated
    (:func:`~magsail_mj.control.reflector_pitch.project_and_saturate`); ``m = B × T / |B|²`` is the
    dipole ⊥ B that makes it. All vectors in the same (body) axes; a zero field gives zero.
    """
    B = np.asarray(B_body, dtype=float)
    T_act, saturated = project_and_saturate(
        np.asarray(T_request_body, dtype=float),
        B,
        saturation=saturation,
        cap_Nm=cap_Nm,
        B_ref_T=B_ref_T,
        m_max_Am2=m_max_Am2,
    )
    B2 = float(B @ B)
    m = cross3(B, T_act) / B2 if B2 > 0 else np.zeros(3)
    return m, cross3(m, B), saturated


# ----------------------------------------------------------------------------- attitude sensors


class RigidBodyAttitude:
    """Attitude of one rigid body: ``(state.xquat[b], R(q)ᵀ state.omega[b])`` (body → world quaternion,
    body-axis rate [rad/s])."""

    def __init__(self, body_id: int) -> None:
        if int(body_id) != body_id or body_id < 1:
            raise ValueError(f"body_id: expected a body index >= 1, got {body_id!r}")
        self.body_id = int(body_id)

    def __call__(self, state: StepState) -> tuple[np.ndarray, np.ndarray]:
        q = np.array(state.xquat[self.body_id], dtype=float)
        return q, quat_to_matrix(q).T @ state.omega[self.body_id]


class LatticeAttitude:
    """Best-fit attitude of a lattice and its backward-difference body rate (``log``
    form) between consecutive calls; the first call returns ``omega0_body``.

    Args:
      reference_nodes: (n, 3) undeformed body coordinates of the nodes [m].
      node_bodies: (n,) MuJoCo body of each node (default ``1 … n``).
      omega0_body: (3,) body rate reported at the first call [rad/s].
    """

    def __init__(
        self,
        reference_nodes: np.ndarray,
        *,
        node_bodies: np.ndarray | None = None,
        omega0_body: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.fit = BestFitRotation(reference_nodes)
        n = self.fit.n
        nb = np.arange(1, n + 1) if node_bodies is None else np.asarray(node_bodies, dtype=np.int64)
        if nb.shape != (n,) or np.any(nb < 1):
            raise ValueError(f"node_bodies: expected {n} body indices >= 1, got shape {nb.shape}")
        w0 = np.asarray(omega0_body, dtype=float)
        if w0.shape != (3,) or not np.all(np.isfinite(w0)):
            raise ValueError(f"omega0_body: expected 3 finite numbers [rad/s], got {omega0_body!r}")
        self.node_bodies = nb
        self.omega0_body = w0
        self._R_prev: np.ndarray | None = None
        self._t_prev = 0.0

    def rotation(self, state: StepState) -> np.ndarray:
        """Best-fit rotation (body → world) of the nodes at ``state``."""
        R, _ = self.fit(state.pos[self.node_bodies])
        return R

    def __call__(self, state: StepState) -> tuple[np.ndarray, np.ndarray]:
        R = self.rotation(state)
        dt = float(state.t) - self._t_prev
        if self._R_prev is None:
            omega = self.omega0_body.copy()
        else:
            omega = body_rate_step(self._R_prev, R, dt) if dt > 0 else np.zeros(3)
        self._R_prev, self._t_prev = R, float(state.t)
        return quat_from_matrix(R), omega


# ----------------------------------------------------------------------------- actuators


class _BodyTorqueActuator:
    """Shared bookkeeping: the last request and delivered torque, and their probes."""

    def __init__(self) -> None:
        self.requested_body_Nm = np.zeros(3)
        self.delivered_body_Nm = np.zeros(3)

    def probes(self) -> dict[str, Callable[[StepState, Any], Any]]:
        """``torque_request_body_Nm`` and ``torque_delivered_body_Nm`` of the last applied step."""
        return {
            "torque_request_body_Nm": lambda s, d: self.requested_body_Nm,
            "torque_delivered_body_Nm": lambda s, d: self.delivered_body_Nm,
        }


class StrutBodyTorqueActuator(_BodyTorqueActuator):
    """Truss: the request as force pairs across ``struts`` (module docstring).

    Args:
      lattice: the lattice; struts: actuated x1- and y1-struts (default every top-layer one);
      torque_axis: ``"local"`` or ``"bestfit"`` (see :class:`~magsail_mj.loads.strut_torque.StrutTorqueLoad`);
      body_offset: body index of node 0.
    """

    name = "strut_body_torque"

    def __init__(
        self,
        lattice: Lattice,
        *,
        struts: np.ndarray | None = None,
        torque_axis: Literal["local", "bestfit"] = "local",
        body_offset: int = 1,
    ) -> None:
        super().__init__()
        if struts is None:
            struts = np.concatenate([lattice.struts_of_kind(kind, layer=1) for kind in ("x_edge", "y_edge")])
        self.pairs = StrutTorqueLoad(
            lattice, struts, command=requested_torque, torque_axis=torque_axis, body_offset=body_offset
        )
        self.attitude = LatticeAttitude(lattice.nodes, node_bodies=np.arange(lattice.n_nodes) + body_offset)

    def couple_world(self, pos: np.ndarray) -> np.ndarray:
        """Total couple ``Σ (r_j − r_i) × F_j`` [N m] (world axes) of the last force pairs."""
        p = self.pairs
        return moment_sum(pos[p.j] - pos[p.i], p.last_force_j)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        self.pairs.add(state, xfrc)
        self.requested_body_Nm = self.pairs.last_command
        if not np.any(self.requested_body_Nm):
            self.delivered_body_Nm = np.zeros(3)
            return
        self.delivered_body_Nm = self.attitude.rotation(state).T @ self.couple_world(state.pos)


class WheelBodyTorqueActuator(_BodyTorqueActuator):
    """Cubesat: the request through the three reaction wheels (spin axes body x, y, z; module docstring).

    Args:
      driver: the wheel driver (motor model and limits).
      wheel_qvel: (3,) qvel indices of the wheel hinges (rotor speeds ω_M relative to the bus).
      wheel_act: (3,) MuJoCo actuator ids of the wheel motors.
      timestep_s: the integration step [s] (the driver's per-step part).

    Needs the simulation's ``MjData`` (:meth:`bind`, done by :func:`magsail_mj.commands.attach`):
    it reads the rotor speeds and writes the motor torques ``T_M`` to ``data.ctrl`` every step.
    """

    name = "wheel_body_torque"

    def __init__(
        self, driver: WheelDriver, *, wheel_qvel: Sequence[int], wheel_act: Sequence[int], timestep_s: float
    ) -> None:
        super().__init__()
        self.driver = driver
        self.wheel_qvel = np.asarray(wheel_qvel, dtype=int)
        self.wheel_act = np.asarray(wheel_act, dtype=int)
        if self.wheel_qvel.shape != (3,) or self.wheel_act.shape != (3,):
            raise ValueError(f"wheel_qvel, wheel_act: expected 3 indices each, got {wheel_qvel!r}, {wheel_act!r}")
        if not (math.isfinite(timestep_s) and timestep_s > 0):
            raise ValueError(f"timestep_s: must be > 0 s, got {timestep_s!r}")
        self.timestep_s = float(timestep_s)
        self.wheel_torque_Nm = np.zeros(3)
        self._data: Any = None

    def bind(self, data: Any) -> None:
        """Use ``data`` (the simulation's ``MjData``) for rotor speeds and motor commands."""
        self._data = data

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        if self._data is None:
            raise RuntimeError("WheelBodyTorqueActuator: not bound to the simulation's MjData (use attach)")
        u = requested_torque(state)
        omega_M = self._data.qvel[self.wheel_qvel]
        T_M = self.driver.motor_torque(self.driver.command(u, omega_M), omega_M, self.timestep_s)
        self._data.ctrl[self.wheel_act] = T_M
        self.requested_body_Nm = u
        self.wheel_torque_Nm = T_M
        self.delivered_body_Nm = self.driver.body_torque(T_M, omega_M)

    def probes(self) -> dict[str, Callable[[StepState, Any], Any]]:
        """Request and delivered torque, and ``wheel_torque_Nm`` (motor torques T_M)."""
        return {**super().probes(), "wheel_torque_Nm": lambda s, d: self.wheel_torque_Nm}


class CoilBodyTorqueActuator(_BodyTorqueActuator):
    """Reflector: the request through the coil paths as a dipole ⊥ B (module docstring).

    Args:
      body_id: the plate body.
      field_body: ``(t, R) → B`` (3,) field in body axes [T] for the attitude ``R`` (body → world).
      saturation, cap_Nm, B_ref_T, m_max_Am2: the limits of
        :func:`~magsail_mj.control.reflector_pitch.project_and_saturate`.
    """

    name = "coil_body_torque"

    def __init__(
        self,
        body_id: int,
        *,
        field_body: Callable[[float, np.ndarray], np.ndarray],
        saturation: Literal["norm", "field_scaled", "per_path"],
        cap_Nm: float,
        B_ref_T: float,
        m_max_Am2: Sequence[float],
    ) -> None:
        super().__init__()
        if saturation not in ("norm", "field_scaled", "per_path"):
            raise ValueError(f"saturation: must be 'norm', 'field_scaled' or 'per_path', got {saturation!r}")
        m_max = np.asarray(m_max_Am2, dtype=float)
        if m_max.shape != (3,) or not np.all(m_max > 0):
            raise ValueError(f"m_max_Am2: expected 3 dipole limits > 0 [A m²], got {m_max_Am2!r}")
        for key, v in (("cap_Nm", cap_Nm), ("B_ref_T", B_ref_T)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{key}: must be > 0, got {v!r}")
        self.body_id = int(body_id)
        self.field_body = field_body
        self.limits = {
            "saturation": saturation,
            "cap_Nm": float(cap_Nm),
            "B_ref_T": float(B_ref_T),
            "m_max_Am2": m_max,
        }
        self.dipole_body_Am2 = np.zeros(3)
        self.B_body_T = np.zeros(3)
        self.saturated = False

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        R = quat_to_matrix(state.xquat[self.body_id])
        T = requested_torque(state)
        B = np.asarray(self.field_body(state.t, R), dtype=float)
        m, delivered, sat = coil_torque(T, B, **self.limits)
        self.requested_body_Nm, self.delivered_body_Nm = T, delivered
        self.dipole_body_Am2, self.B_body_T, self.saturated = m, B, sat
        xfrc[self.body_id, 3:] += R @ delivered

    def probes(self) -> dict[str, Callable[[StepState, Any], Any]]:
        """Request and delivered torque, ``dipole_body_Am2``, ``B_body_T`` and ``saturated`` (0/1)."""
        return {
            **super().probes(),
            "dipole_body_Am2": lambda s, d: self.dipole_body_Am2,
            "B_body_T": lambda s, d: self.B_body_T,
            "saturated": lambda s, d: np.int8(self.saturated),
        }


# ----------------------------------------------------------------------------- per spacecraft


def _concept(sim: Any) -> str:
    cfg = getattr(sim, "cfg", None)
    concept = getattr(cfg, "concept", None)
    if concept not in ("truss_magnetorquer", "cnusail", "reflector") or getattr(sim, "scenario", None) is None:
        raise ValueError(
            f"sim: body-torque actuators exist for a loaded truss_magnetorquer, cnusail or reflector "
            f"simulation (magsail_mj.load), got concept {concept!r}"
        )
    return concept


def attitude_sensor(sim: Any) -> RigidBodyAttitude | LatticeAttitude:
    """The attitude sensor of a loaded simulation's spacecraft: the lattice best fit (truss, with the
    config's ``initial.omega0_rad_s`` at the first sample), the bus (cubesat) or the plate (reflector)."""
    concept, sc = _concept(sim), sim.scenario
    if concept == "truss_magnetorquer":
        lat = sc.tm.lattice
        return LatticeAttitude(
            lat.nodes, node_bodies=np.arange(lat.n_nodes) + 1, omega0_body=sc.cfg.initial.omega0_rad_s
        )
    return RigidBodyAttitude(sc.idx.bus if concept == "cnusail" else sc.idx.plate)


def body_torque_actuator(sim: Any) -> StrutBodyTorqueActuator | WheelBodyTorqueActuator | CoilBodyTorqueActuator:
    """The :class:`~magsail_mj.commands.BodyTorque` actuator of a loaded simulation's spacecraft, from its
    config: truss → every top-layer x1/y1 strut with ``actuators.torque_axis``; cubesat → the
    ``[actuators.wheels]`` driver; reflector → the coil capability with ``control.saturation``
    (``"box"`` of the B-dot runs taken as ``"per_path"``) and the run's field (inertial, body-fixed
    or the orbit's dipole field)."""
    concept, sc = _concept(sim), sim.scenario
    cfg = sc.cfg
    if concept == "truss_magnetorquer":
        return StrutBodyTorqueActuator(sc.tm.lattice, torque_axis=cfg.actuators.torque_axis)
    if concept == "cnusail":
        w = cfg.actuators.wheels
        driver = WheelDriver(w.motor_params(), model=w.model, electrical=w.electrical)
        return WheelBodyTorqueActuator(
            driver, wheel_qvel=sc.idx.wheel_qvel, wheel_act=sc.idx.wheel_act, timestep_s=cfg.sim.timestep_s
        )
    if cfg.field.model == "dipole":
        orbit = sc.orbit
        field = lambda t, R: R.T @ orbit.field(t)  # noqa: E731
    else:
        field = sc.field_body_fn()
    mode = cfg.control.saturation_mode
    return CoilBodyTorqueActuator(
        sc.idx.plate,
        field_body=field,
        saturation="per_path" if mode == "box" else mode,
        cap_Nm=sc.cap.cap_Nm,
        B_ref_T=cfg.coil.B_ref_T,
        m_max_Am2=sc.cap.m_max_Am2,
    )
