r"""MjSpec builder of the CNUSAIL-1 cubesat: one rigid bus (+ sail) with three reaction-wheel rotors.

Source: Yoo et al. 2016, Table 2 (mass properties); the body tree is ours. The tree is::

    world                         gravity off, contacts/constraints off (free space)
      bus          freejoint ``bus_free``; explicit inertial at the body origin (= the CM)
                   mass  m − 3 m_r,  diaginertia  I_table2 − (J_s + 2 J_t) on every axis
                   geoms (massless, visual): bus box at the bus centroid, sail plate (deployed),
                   four boom capsules (deployed), body-axis bars x (red), y (green), z (blue)
        rw_x       hinge ``rw_x_spin`` along body x at the CM; inertial (J_s, J_t, J_t), mass m_r;
        rw_y       joint damping K_B (viscous bearing friction on the relative speed ω_M)
        rw_z       ... each with a rotor disc and an off-axis tick so its spin is visible
      mk_sun, mk_vel, mk_nadir, mk_field   (optional display markers, see below)

Composite inertia. The rotors sit at the CM, so they add no parallel-axis term; each adds its
spin inertia J_s on its own axis and its transverse inertia J_t on the two others, i.e.
J_s + 2 J_t on every axis (9e-6 kg m² with the defaults). The hub inertia is Table 2 minus
that, so the **composite** inertia of the bus subtree equals Table 2 exactly (a test
reads it from the compiled model). The rotors must be axisymmetric (J_t equal on both transverse
axes): at Ω ≈ 733 rad/s and a 0.1 s step the hinge angle advances ~73 rad per step, harmless only
because the rotor inertia does not depend on that angle.

Actuators: one ``motor`` per wheel (``rw_x_motor`` …, gear 1, ``ctrl`` = motor torque T_M [N m]
on the rotor, its reaction on the bus), with a force range well above τ_max; the DC-motor driver
(:mod:`magsail_mj.loads.actuators_cubesat`) does the real limiting.

Display markers (``markers=True``). MuJoCo's renderer replays only ``qpos``, so the Sun,
velocity, nadir and magnetic-field directions are drawn by four massless-looking marker bodies,
each on a ``ball`` joint at the world origin with an arrow along its local +z. They are not
attached to the spacecraft, feel no force and have zero velocity, so they stay at rest during the
simulation and do not interact with the bus (a test checks the bus motion is unchanged); their
``qpos`` quaternions are filled in from the environment when a run is post-processed, so the video
shows the directions. A directional light rides on the Sun marker, so the sail is lit from the Sun.

MuJoCo 4 note: ``spec.to_xml()`` keeps an explicit body mass only when ``ipos`` is set, so every
explicit inertial sets ``ipos`` (the round trip is tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from magsail_mj.checks import require_positive
from magsail_mj.mjcf.common import INTEGRATORS, add_marker_body, add_sun_light, free_space_spec, set_view
from magsail_mj.quaternion import quat_z_to

__all__ = [
    "CubesatModelParams",
    "build_cubesat_spec",
    "WHEEL_NAMES",
    "MARKER_NAMES",
    "INTEGRATORS",
    "cubesat_indices",
    "CubesatIndices",
]

WHEEL_NAMES = ("rw_x", "rw_y", "rw_z")
MARKER_NAMES = ("mk_sun", "mk_vel", "mk_nadir", "mk_field")
_MARKER_RGBA = {
    "mk_sun": (1.0, 0.85, 0.1, 1.0),
    "mk_vel": (0.1, 0.9, 0.2, 1.0),
    "mk_nadir": (0.2, 0.5, 1.0, 1.0),
    "mk_field": (0.9, 0.2, 0.9, 1.0),
}
_AXIS_RGBA = ((0.9, 0.1, 0.1, 1.0), (0.1, 0.8, 0.1, 1.0), (0.1, 0.3, 1.0, 1.0))
_BUS_RGBA = (0.55, 0.57, 0.62, 0.55)
_SAIL_FRONT_RGBA = (0.95, 0.78, 0.35, 0.85)  # +z face (front), aluminised side shown golden
_SAIL_BACK_RGBA = (0.75, 0.78, 0.85, 0.85)  # −z face (back)
_BOOM_RGBA = (0.25, 0.25, 0.25, 1.0)
_ROTOR_RGBA = (0.3, 0.3, 0.35, 1.0)
_TICK_RGBA = (1.0, 0.4, 0.0, 1.0)


@dataclass(frozen=True)
class CubesatModelParams:
    """Inputs of :func:`build_cubesat_spec` (SI units; defaults:; deployed).

    Attributes:
      configuration: ``"stowed"`` (bus only) or ``"deployed"`` (bus + sail + booms).
      mass_kg: total mass m, rotors included (Table 2: 4 kg).
      inertia_kgm2: composite principal inertia (I_x, I_y, I_z) about the CM, rotors included
        (Table 2; deployed (0.3104, 0.3121, 0.5757), stowed (0.0506, 0.0506, 0.010)).
      bus_size_m: bus box edges (x, y, z) (3U: 0.1 × 0.1 × 0.3, long axis z_B).
      bus_centroid_m: bus box centre relative to the CM, body axes.
      sail_side_m: side of the square sail (2 m); sail_centre_m: centre of the sail plane
        relative to the CM (the centre of pressure r_cp).
      sail_thickness_m: drawn thickness of the sail plate (visual only).
      rotor_mass_kg, rotor_spin_inertia_kgm2, rotor_transverse_inertia_kgm2: per rotor
        (default 0.03 kg, 4.5e-6, 2.25e-6 kg m²).
      wheel_damping_Nms: joint damping = viscous bearing friction K_B (Yoo et al. 2016, Eqs. 8–11).
      motor_force_limit_Nm: actuator force range ± this (must exceed the largest τ_max used).
      timestep_s, integrator: MuJoCo option (default RK4 at 0.1 s).
      markers: add the display marker bodies (module docstring).
      name: model name.
    """

    configuration: Literal["stowed", "deployed"] = "deployed"
    mass_kg: float = 4.0
    inertia_kgm2: tuple[float, float, float] = (0.3104, 0.3121, 0.5757)
    bus_size_m: tuple[float, float, float] = (0.1, 0.1, 0.3)
    bus_centroid_m: tuple[float, float, float] = (0.0, 0.0, -0.05)
    sail_side_m: float = 2.0
    sail_centre_m: tuple[float, float, float] = (0.01, 0.01, 0.10)
    sail_thickness_m: float = 0.004
    rotor_mass_kg: float = 0.03
    rotor_spin_inertia_kgm2: float = 4.5e-6
    rotor_transverse_inertia_kgm2: float = 2.25e-6
    wheel_damping_Nms: float = 1.0e-8
    motor_force_limit_Nm: float = 1.96e-3
    timestep_s: float = 0.1
    integrator: str = "RK4"
    solver_tolerance: float | None = None
    markers: bool = True
    name: str = "cnusail"

    def __post_init__(self) -> None:
        if self.configuration not in ("stowed", "deployed"):
            raise ValueError(f"configuration: must be 'stowed' or 'deployed', got {self.configuration!r}")
        require_positive(
            self,
            (
                "mass_kg",
                "sail_side_m",
                "sail_thickness_m",
                "rotor_mass_kg",
                "rotor_spin_inertia_kgm2",
                "rotor_transverse_inertia_kgm2",
                "motor_force_limit_Nm",
                "timestep_s",
            ),
        )
        if self.wheel_damping_Nms < 0:
            raise ValueError(f"wheel_damping_Nms: must be >= 0, got {self.wheel_damping_Nms!r}")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator: must be one of {sorted(INTEGRATORS)}, got {self.integrator!r}")
        if 3 * self.rotor_mass_kg >= self.mass_kg:
            raise ValueError(
                f"rotor_mass_kg: three rotors ({3 * self.rotor_mass_kg} kg) must weigh less than "
                f"mass_kg ({self.mass_kg} kg)"
            )
        hub = self.hub_inertia_kgm2
        if np.any(hub <= 0):
            raise ValueError(
                f"inertia_kgm2: must exceed the rotors' J_s + 2 J_t = {self.rotor_sum_kgm2:g} kg m² "
                f"on every axis, got {self.inertia_kgm2}"
            )
        a, b, c = hub
        if a + b < c or b + c < a or a + c < b:
            raise ValueError(f"inertia_kgm2: hub inertia {hub.tolist()} violates the triangle inequality")

    @property
    def rotor_sum_kgm2(self) -> float:
        """J_s + 2 J_t: what the three rotors add to each composite principal moment [kg m²]."""
        return self.rotor_spin_inertia_kgm2 + 2.0 * self.rotor_transverse_inertia_kgm2

    @property
    def hub_inertia_kgm2(self) -> np.ndarray:
        """Principal inertia of the bus body alone: Table 2 − (J_s + 2 J_t) [kg m²]."""
        return np.asarray(self.inertia_kgm2, dtype=float) - self.rotor_sum_kgm2

    def rotor_inertia(self, axis: int) -> list[float]:
        """Diagonal inertia of rotor ``axis`` (0, 1, 2) in bus axes: J_s on its axis, J_t elsewhere."""
        d = [self.rotor_transverse_inertia_kgm2] * 3
        d[axis] = self.rotor_spin_inertia_kgm2
        return d


def build_cubesat_spec(params: CubesatModelParams | None = None) -> mujoco.MjSpec:
    """Return the ``MjSpec`` of the CNUSAIL-1 cubesat (see the module docstring)."""
    p = params or CubesatModelParams()
    spec = free_space_spec(
        name=p.name, timestep_s=p.timestep_s, integrator=p.integrator, solver_tolerance=p.solver_tolerance
    )
    deployed = p.configuration == "deployed"
    reach = (p.sail_side_m / math.sqrt(2.0) + 0.1) if deployed else 0.3
    set_view(spec, extent=2 * reach, headlight_diffuse=[0.35, 0.35, 0.35], headlight_ambient=[0.25, 0.25, 0.25])
    nogeo = dict(contype=0, conaffinity=0, mass=0)

    wb = spec.worldbody
    bus = wb.add_body(name="bus")
    bus.add_freejoint(name="bus_free")
    bus.explicitinertial = True
    bus.mass = p.mass_kg - 3.0 * p.rotor_mass_kg
    bus.ipos = [0.0, 0.0, 0.0]
    bus.inertia = p.hub_inertia_kgm2.tolist()
    half = [x / 2 for x in p.bus_size_m]
    bus.add_geom(
        name="bus_box",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=half,
        pos=list(p.bus_centroid_m),
        rgba=list(_BUS_RGBA),
        **nogeo,
    )
    # body axes (x red, y green, z blue), from the CM
    L_ax = 0.6 * reach if deployed else 0.25
    for k, rgba in enumerate(_AXIS_RGBA):
        end = [0.0, 0.0, 0.0]
        end[k] = L_ax
        bus.add_geom(
            name=f"axis_{'xyz'[k]}",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0, 0, 0, *end],
            size=[0.006 * max(1.0, reach), 0, 0],
            rgba=list(rgba),
            group=2,
            **nogeo,
        )
    if deployed:
        cx, cy, cz = p.sail_centre_m
        s2 = p.sail_side_m / 2
        t = p.sail_thickness_m / 2
        # two thin plates: front (+z) golden, back (−z) silver, so the lit face can be told apart
        bus.add_geom(
            name="sail_front",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[s2, s2, t / 2],
            pos=[cx, cy, cz + t / 2],
            rgba=list(_SAIL_FRONT_RGBA),
            **nogeo,
        )
        bus.add_geom(
            name="sail_back",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[s2, s2, t / 2],
            pos=[cx, cy, cz - t / 2],
            rgba=list(_SAIL_BACK_RGBA),
            **nogeo,
        )
        # four booms along the sail diagonals, length sqrt(2) m each (rendering only)
        boom = p.sail_side_m / math.sqrt(2.0)
        for k, (sx, sy) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
            d = np.array([sx, sy, 0.0]) / math.sqrt(2.0)
            a = np.array([cx, cy, cz - t - 0.004])
            bus.add_geom(
                name=f"boom_{k}",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[*a.tolist(), *(a + boom * d).tolist()],
                size=[0.005, 0, 0],
                rgba=list(_BOOM_RGBA),
                **nogeo,
            )

    r_rotor = 0.02
    for k, name in enumerate(WHEEL_NAMES):
        axis = [0.0, 0.0, 0.0]
        axis[k] = 1.0
        rw = bus.add_body(name=name, pos=[0.0, 0.0, 0.0])
        rw.add_joint(name=f"{name}_spin", type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis, damping=p.wheel_damping_Nms)
        rw.explicitinertial = True
        rw.mass = p.rotor_mass_kg
        rw.ipos = [0.0, 0.0, 0.0]
        rw.inertia = p.rotor_inertia(k)
        # rotor disc (visual) offset along its axis so the three do not overlap, and a tick
        off = np.array(axis) * 0.03
        q = quat_z_to(np.array(axis))
        rw.add_geom(
            name=f"{name}_disc",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[r_rotor, 0.004, 0],
            pos=off.tolist(),
            quat=q,
            rgba=list(_ROTOR_RGBA),
            group=1,
            **nogeo,
        )
        perp = np.roll(np.array(axis), 1)
        rw.add_geom(
            name=f"{name}_tick",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[0.004, 0.004, 0.004],
            pos=(off + perp * r_rotor * 0.8 + np.array(axis) * 0.005).tolist(),
            rgba=list(_TICK_RGBA),
            group=1,
            **nogeo,
        )
        act = spec.add_actuator(name=f"{name}_motor", target=f"{name}_spin", trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_motor()
        act.gear[0] = 1.0
        act.ctrllimited = 1
        act.ctrlrange = [-p.motor_force_limit_Nm, p.motor_force_limit_Nm]
        act.forcelimited = 1
        act.forcerange = [-p.motor_force_limit_Nm, p.motor_force_limit_Nm]

    if p.markers:
        L = 1.15 * reach
        for name in MARKER_NAMES:
            mk = add_marker_body(wb, name)
            rgba = list(_MARKER_RGBA[name])
            mk.add_geom(
                name=f"{name}_shaft",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0.55 * L, 0, 0, 0.95 * L],
                size=[0.008 * max(1.0, reach), 0, 0],
                rgba=rgba,
                group=2,
                **nogeo,
            )
            mk.add_geom(
                name=f"{name}_head",
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                pos=[0, 0, L],
                size=[0.03 * max(1.0, reach), 0, 0],
                rgba=rgba,
                group=2,
                **nogeo,
            )
            if name == "mk_sun":
                add_sun_light(mk, height=3 * L, diffuse=[0.75, 0.75, 0.7])
    return spec


@dataclass(frozen=True)
class CubesatIndices:
    """Address book of a compiled cubesat model (bus body, qpos/qvel slices, wheels, markers)."""

    bus: int
    q_pos: slice  # bus position qpos[0:3]
    q_quat: slice  # bus quaternion qpos[3:7] (world ← body, scalar-first)
    v_lin: slice  # bus linear velocity qvel[0:3] (world)
    v_ang: slice  # bus angular velocity qvel[3:6] (body components)
    wheel_bodies: np.ndarray
    wheel_qpos: np.ndarray
    wheel_qvel: np.ndarray  # relative speeds ω_M
    wheel_act: np.ndarray
    marker_qpos: dict[str, int]


def cubesat_indices(model: mujoco.MjModel) -> CubesatIndices:
    """Indices of the bus, wheels and markers in a model built by :func:`build_cubesat_spec`."""
    bus = model.body("bus").id
    ja = model.body_jntadr[bus]
    qa, va = int(model.jnt_qposadr[ja]), int(model.jnt_dofadr[ja])
    wb, wq, wv, wa = [], [], [], []
    for name in WHEEL_NAMES:
        j = model.joint(f"{name}_spin")
        wb.append(model.body(name).id)
        wq.append(int(model.jnt_qposadr[j.id]))
        wv.append(int(model.jnt_dofadr[j.id]))
        wa.append(model.actuator(f"{name}_motor").id)
    markers = {}
    for name in MARKER_NAMES:
        try:
            j = model.joint(f"{name}_ball")
        except KeyError:
            continue
        markers[name] = int(model.jnt_qposadr[j.id])
    return CubesatIndices(
        bus=bus,
        q_pos=slice(qa, qa + 3),
        q_quat=slice(qa + 3, qa + 7),
        v_lin=slice(va, va + 3),
        v_ang=slice(va + 3, va + 6),
        wheel_bodies=np.array(wb),
        wheel_qpos=np.array(wq),
        wheel_qvel=np.array(wv),
        wheel_act=np.array(wa),
        marker_qpos=markers,
    )
