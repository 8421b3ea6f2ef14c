"""Model builder of the current-loops concept: config → lattice, masses, springs, circuits → MjSpec.

Robb et al. 2022b. The lattice and its springs are the truss concept's
(:mod:`magsail_mj.lattice.geometry`, :func:`magsail_mj.lattice.properties.strut_stiffness`) with
uniform particle masses and no tendon damping, as a structure (:func:`loops_structure`: its
stiffness model and modal damping) built by :func:`magsail_mj.structure.mjcf.build_structure_spec`
— the same model arrays as the lattice builder gives (tests/test_structure_truss.py); the circuits
are :mod:`magsail_mj.geometry.current_loops`. ``slew_rigid`` uses one free
body with the undeformed lattice's inertia (:func:`rigid_plate_spec`). Also here: the concept's
own loads (the work ledger, held-force wrapper and the rigid surrogate's dipole torque).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from magsail_mj.estimation.attitude import matrix_from_quat
from magsail_mj.geometry.current_loops import Circuit
from magsail_mj.geometry.current_loops import circuits as make_circuits
from magsail_mj.lattice.geometry import Lattice, axial_rigidity_from_EI, make_lattice
from magsail_mj.lattice.properties import strut_stiffness
from magsail_mj.mjcf.common import free_space_spec
from magsail_mj.structure.generators.plates import lattice_structure
from magsail_mj.structure.mjcf import build_structure_spec
from magsail_mj.structure.model import ModalDamping, Structure
from magsail_mj.concepts.current_loops.config import CurrentLoopsConfig, loop_currents

__all__ = [
    "LoopsModel",
    "make_loops_model",
    "loops_structure",
    "rigid_plate_spec",
    "loop_currents",
    "WorkLedger",
    "HeldForces",
    "RigidLoopTorqueLoad",
]


@dataclass
class LoopsModel:
    """Everything derived from the structural and loop tables of a config.

    ``masses`` (n,) [kg] equal particle masses σ D² / n; ``k`` (S,) spring constants [N/m];
    ``EA_N`` the strut axial stiffness [N]; ``circuits`` in config order with their full currents
    ``currents_A`` [A] and ``sizing`` records; ``spec`` the flexible lattice's MjSpec.
    """

    lattice: Lattice
    masses: np.ndarray
    k: np.ndarray
    EA_N: float
    calibration_factor: float
    circuits: list[Circuit]
    currents_A: np.ndarray
    sizing: list[dict[str, Any]]
    spec: mujoco.MjSpec
    structure: Structure | None = None


def make_loops_model(cfg: CurrentLoopsConfig) -> LoopsModel:
    """Lattice, masses, springs, circuits, currents and the MjSpec (no tendon damping).

    ``k`` always holds the spring constants (modes, strain energy); the MjSpec's tendons carry
    them only for ``stiffness.form = "tendon"`` and have zero stiffness for the linear forms,
    whose forces are a load (:class:`~magsail_mj.lattice.linear_stiffness.LinearStiffnessLoad`).
    """
    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    M = cfg.mass.areal_density_kg_m2 * cfg.lattice.side_m**2
    masses = np.full(lat.n_nodes, M / lat.n_nodes)
    k, c = strut_stiffness(lat, EI_Nm2=cfg.stiffness.EI_Nm2, calibration=cfg.stiffness.calibration)
    EA = float(k[0] * lat.rest_length[0])
    circuits = make_circuits(lat, cfg.loops.expanded(), d_return=cfg.loops.d_return)
    currents, sizing = loop_currents(cfg)
    structure = loops_structure(cfg, lat, masses=masses, calibration_factor=c)
    spec = build_structure_spec(
        structure,
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        name=f"current_loops_{cfg.scenario}",
        solver_tolerance=cfg.sim.solver_tolerance,
        node_radius_m=0.04 * lat.cube_edge_m,  # the truss builder's sizes
        member_width_m=0.015 * lat.cube_edge_m,
        extent_m=cfg.lattice.side_m,
    )
    for flag in ("CONSTRAINT", "EQUALITY", "FRICTIONLOSS", "LIMIT"):
        spec.option.disableflags |= int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag}"))
    return LoopsModel(
        lattice=lat,
        masses=masses,
        k=k,
        EA_N=EA,
        calibration_factor=c,
        circuits=circuits,
        currents_A=currents,
        sizing=sizing,
        spec=spec,
        structure=structure,
    )


def loops_structure(
    cfg: CurrentLoopsConfig, lat: Lattice, *, masses: np.ndarray, calibration_factor: float
) -> Structure:
    """The lattice as a :class:`Structure`: uniform particles, struts of ``EA = c · 2 EI / (N a²)``
    (Eq. 8) without dashpots, the stiffness model of ``stiffness.form`` (``"tendon"``: each
    strut's spring; the linear forms: a load, :data:`~magsail_mj.structure.model.STIFFNESS_MODELS`)
    and the Caughey modal damping of ``[damping]`` when enabled."""
    EA = calibration_factor * axial_rigidity_from_EI(
        cfg.stiffness.EI_Nm2, nodes_per_side=lat.nodes_per_side, cube_edge_m=lat.cube_edge_m
    )
    d = cfg.damping
    damping = (
        ModalDamping(
            schedule=d.schedule,
            xi_low=d.xi_low,
            n_low=d.n_low,
            xi_cap=d.xi_cap,
            frame=d.frame,
            form=d.form,
            rtol=d.rtol,
        )
        if d.enabled
        else None
    )
    structure = lattice_structure(
        lat, masses_kg=masses, EA_N=EA, damping_Ns_m=0.0, name=f"current_loops_{cfg.scenario}"
    )
    form = "members" if cfg.stiffness.form == "tendon" else cfg.stiffness.form
    return dataclasses.replace(structure, stiffness_model=form, modal_damping=damping)


def rigid_plate_spec(cfg: CurrentLoopsConfig, inertia: np.ndarray, mass: float) -> mujoco.MjSpec:
    """One free body with the undeformed lattice's inertia tensor (``slew_rigid``)."""
    spec = free_space_spec(
        name="current_loops_slew_rigid",
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        solver_tolerance=cfg.sim.solver_tolerance,
    )
    D = cfg.lattice.side_m
    w = D / cfg.lattice.units
    spec.stat.extent = float(D)
    spec.visual.map.zfar = 50.0
    spec.visual.global_.offwidth = 1920
    spec.visual.global_.offheight = 1080
    spec.worldbody.add_light(
        name="sun",
        pos=[0, 0, 3 * D],
        dir=[0, 0, -1],
        type=int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL),
        diffuse=[0.8, 0.8, 0.8],
    )
    body = spec.worldbody.add_body(name="plate", pos=[0, 0, 0])
    body.add_freejoint(name="plate_free")
    body.explicitinertial = True
    body.ipos = [0.0, 0.0, 0.0]  # without it to_xml() drops the explicit inertial (MuJoCo 4)
    body.mass = float(mass)
    body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[D / 2, D / 2, w / 2],
        contype=0,
        conaffinity=0,
        mass=0.0,
        density=0.0,
        rgba=[0.75, 0.75, 0.8, 0.6],
    )
    return spec


# ---------------------------------------------------------------------------------- loads


class WorkLedger:
    """Work done by held nodal forces: ``W += F_{k−1} · (x_k − x_{k−1})`` (exact for forces held
    over the step). Put it after the loads it watches; they expose ``last_forces`` (n, 3)."""

    name = "work_ledger"

    def __init__(self, watched: dict[str, Any], node_bodies: np.ndarray):
        self.watched = watched
        self.node_bodies = node_bodies
        self.work = {k: 0.0 for k in watched}
        self._x = None
        self._f: dict[str, np.ndarray] = {}

    def add(self, state, xfrc: np.ndarray) -> None:
        x = state.pos[self.node_bodies]
        if self._x is not None:
            dx = x - self._x
            for k, f in self._f.items():
                self.work[k] += float(np.einsum("ij,ij->", f, dx))
        self._x = x.copy()
        for k, load in self.watched.items():
            f = getattr(load, "last_forces", None)
            if f is not None:
                self._f[k] = np.array(f, copy=True)

    def values(self, pos: np.ndarray | None = None) -> np.ndarray:
        """Work of every watched load up to now; with the current positions ``pos`` (all bodies)
        the last held step is included (the recorder samples before the loads run)."""
        out = np.array([self.work[k] for k in self.watched])
        if pos is not None and self._x is not None:
            dx = pos[self.node_bodies] - self._x
            out += [float(np.einsum("ij,ij->", self._f[k], dx)) if k in self._f else 0.0 for k in self.watched]
        return out


class HeldForces:
    """Wraps a load with a ``forces(pos, vel)`` method; keeps ``last_forces`` for the ledger."""

    def __init__(self, load, body_offset: int = 1):
        self.load = load
        self.name = load.name
        self.n = load.n
        self._sl = slice(body_offset, body_offset + load.n)
        self.last_forces = np.zeros((load.n, 3))

    def add(self, state, xfrc: np.ndarray) -> None:
        self.last_forces = self.load.forces(state.pos[self._sl], state.vel[self._sl])
        xfrc[self._sl, :3] += self.last_forces


class RigidLoopTorqueLoad:
    """Dipole torque of the loops on the rigid surrogate: ``T = (R Σ_L I_L a_L) × B`` (world)."""

    name = "rigid_loop_torque"

    def __init__(self, body_id: int, areas_body: np.ndarray, field_world: np.ndarray | None = None):
        self.body_id = int(body_id)
        self.areas_body = np.asarray(areas_body, dtype=float)  # (L, 3)
        self.field_world = field_world
        self.last_torque = np.zeros(3)

    def add(self, state, xfrc: np.ndarray) -> None:
        cmd = state.ctrl
        if cmd is None:
            return
        R = matrix_from_quat(state.xquat[self.body_id])
        m_world = R @ (np.asarray(cmd.currents_A) @ self.areas_body)
        B = self.field_world if self.field_world is not None else state.env.B_eci
        self.last_torque = np.cross(m_world, B)
        xfrc[self.body_id, 3:] += self.last_torque
