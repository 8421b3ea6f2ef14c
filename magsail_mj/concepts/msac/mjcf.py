r"""MjSpec builder of the MSAC multibody model: a free bus and two hinged, sliding wings.

The tree is::

    world
      bus            freejoint; explicit box inertial; box geom (visual)
        w1_root      pos (+r0, 0, 0), quat identity
          w1_bend    hinge, axis (0, 0, 1)          (bending DOF, φ)
          (placeholder inertial: root_mass_kg, root_inertia_kgm2)
          w1         pos (0, 0, 0)
            w1_ext   slide, axis (1, 0, 0)          (extension DOF, s; springref 0)
            inertial at (ℓ/2, 0, 0): mass m, diaginertia
                     (m(t²+w²)/12, m(ℓ²+w²)/12, m(ℓ²+t²)/12)
            geom box size (ℓ/2, t/2, w/2) at (ℓ/2, 0, 0)
        w2_root      pos (−r0, 0, 0)
                     point_symmetric: quat (0, 0, 0, 1)  — 180° about Z (wing 1 rotated);
                     mirror:          quat (0, 0, 1, 0)  — 180° about Y, so the hinge axis is
                                      −Z and equal commands flap the wings mirror-wise (only for
                                      the negative test T4)
          … w2_bend, w2, w2_ext as for wing 1 …

Frames: the MuJoCo world is inertial (free space, no orbit, gravity 0, contacts off).
Each wing lies in its body's X–Z plane (length ``ℓ`` along local X, width ``w`` along Z, the
thickness ``t`` along Y), so bending about Z is the transverse flap. The hinge
axis of wing 1 is world Z at ``φ = 0``; with the point-symmetric layout the system centre of
mass stays at the bus centre for any common ``(φ, s)``.

Actuators (all unlimited: ``ctrllimited``/``forcelimited`` false). For every shape
joint ``j`` (order ``w1_bend, w1_ext, w2_bend, w2_ext``):

* ``j_ff``: a ``motor`` (feed-forward torque/force ``τ = g·ctrl``), actuator group 0. Its gear is
  ``g = ff_gear`` (default 10⁶), not 1: MuJoCo treats any ``|ctrl| > mjMAXVAL = 10¹⁰``
  as invalid and silently zeroes all controls for that step (warning ``BADCTRL``), and the
  prescribed motion needs hinge torques of ~10¹⁰ N m (more for faster or mirror-symmetric
  cycles). The force is the same; only the control is scaled;
* ``j_servo``: a ``general`` actuator, ``gainprm = k_p``, ``biastype = affine``,
  ``biasprm = (0, −k_p, −k_d)``, i.e. ``τ = k_p (u − q) − k_d q̇``; with the set-point
  ``u = q_des + (k_d/k_p) q̇_des`` this is ``k_p (q_des − q) + k_d (q̇_des − q̇)`` (a PD servo
  on the prescribed trajectory). ``k_p = J ω_s²``, ``k_d = 2 J ω_s``, ``ω_s = servo_omega_dt / timestep``, ``J`` the
  joint's own inertia (wing MOI about the hinge at rest length, ``m(ℓ²+t²)/12 + m(ℓ/2)²``, for
  the hinge; the wing mass for the slide). Actuator group 1, so a computed-torque run can switch
  the servos off with ``opt.disableactuator = 1 << 1``.

  The set-point is the servo's *activation* ``u = act`` with ``dyntype = integrator``
  (``acṫ = ctrl``), and the control is the set-point's rate over the step,
  ``ctrl_k = (u(t_{k+1}) − u(t_k))/δt``. RK4 integrates ``act`` with the state, so inside every
  step ``u`` moves linearly from ``u(t_k)`` to ``u(t_{k+1})`` instead of being held. Measured:
  with a held set-point the servo force swings by ~10⁹ N m inside each step (``q̇`` changes by
  ~60 rad/s per step against a fixed ``q̇_des``), and RK4's truncation of that stiff, fast term
  broke the conservation of the total angular momentum by 0.25 N m s per simulated second
  (second order in δt), which over 600 s would bias the secular rate by ~2 %; with the
  interpolated set-point the servo force stays at the size of the tracking error.

Control vector order: the four ``_ff`` motor controls (torque/gear), then the four ``_servo``
set-point rates; ``act`` holds the four set-points.

Sensors (values refer to the state at the *start* of a step, as MuJoCo computes them in
``mj_forward`` before integrating): ``bus_angmom`` (``subtreeangmom`` of the bus subtree =
the whole spacecraft, world axes, about its centre of mass) [N m s], ``bus_angvel``
(``frameangvel`` of the bus, world axes) [rad/s], and ``<joint>_frc`` (``jointactuatorfrc``:
total actuator torque [N m] / force [N] on each shape joint).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from magsail_mj.config import check_finite_fields
from magsail_mj.mjcf.common import INTEGRATORS, free_space_spec, set_view

__all__ = [
    "MsacModelParams",
    "build_msac_spec",
    "SHAPE_JOINTS",
    "ACTUATOR_ORDER",
    "SENSOR_NAMES",
    "INTEGRATORS",
    "shape_indices",
]

SHAPE_JOINTS = ("w1_bend", "w1_ext", "w2_bend", "w2_ext")
ACTUATOR_ORDER = tuple(f"{j}_ff" for j in SHAPE_JOINTS) + tuple(f"{j}_servo" for j in SHAPE_JOINTS)
SENSOR_NAMES = ("bus_angmom", "bus_angvel") + tuple(f"{j}_frc" for j in SHAPE_JOINTS)

BUS_RGBA = (0.80, 0.72, 0.35, 1.0)
WING_RGBA = ((0.20, 0.40, 0.85, 1.0), (0.85, 0.35, 0.20, 1.0))
MARKER_RGBA = (0.9, 0.9, 0.9, 1.0)


@dataclass(frozen=True)
class MsacModelParams:
    """Physical and numerical parameters of the model (SI units).

    Attributes:
      bus_mass_kg: bus mass; its inertia is that of a uniform box of ``bus_size_m``.
      bus_size_m: bus box edge lengths (X, Y, Z) [m].
      wing_length_m: rest length ``ℓ`` of each wing (along its local X) [m].
      wing_width_m: wing width ``w`` (along Z) [m].
      wing_thickness_m: wing thickness ``t`` (along its local Y, in the plane of motion) [m].
      wing_mass_kg: mass ``m`` of each wing [kg].
      hinge_offset_m: distance ``r0`` of each hinge from the bus centre along ±X [m].
      layout: ``point_symmetric`` (the MSAC arrangement) or ``mirror`` (negative test).
      root_mass_kg, root_inertia_kgm2: placeholder inertial of the hinge bodies (MuJoCo needs
        a body between the two joints); kept tiny and included in the exact model.
      slide_stiffness_N_m: slide spring ``k_s`` towards ``s = 0`` (``springref = 0``).
      hinge_damping_Nms, slide_damping_Ns_m: joint damping (default 0).
      timestep_s: MuJoCo ``opt.timestep``.
      integrator: one of :data:`INTEGRATORS`.
      servo_omega_dt: ``ω_s · timestep`` of the joint servos.
      ff_gear: gear of the feed-forward motors (control = torque / gear), see module docs.
      name: model name.
    """

    bus_mass_kg: float = 3000.0
    bus_size_m: tuple[float, float, float] = (2.0, 2.0, 3.0)
    wing_length_m: float = 8.0
    wing_width_m: float = 3.0
    wing_thickness_m: float = 0.03
    wing_mass_kg: float = 60.0
    hinge_offset_m: float = 1.0
    layout: Literal["point_symmetric", "mirror"] = "point_symmetric"
    root_mass_kg: float = 1e-3
    root_inertia_kgm2: float = 1e-6
    slide_stiffness_N_m: float = 0.0
    hinge_damping_Nms: float = 0.0
    slide_damping_Ns_m: float = 0.0
    timestep_s: float = 5e-6
    integrator: str = "RK4"
    solver_tolerance: float | None = None
    servo_omega_dt: float = 0.05
    ff_gear: float = 1e6
    name: str = "msac"

    def __post_init__(self) -> None:
        check_finite_fields(
            self,
            positive=(
                "bus_mass_kg",
                "wing_length_m",
                "wing_width_m",
                "wing_thickness_m",
                "wing_mass_kg",
                "root_mass_kg",
                "root_inertia_kgm2",
                "timestep_s",
                "servo_omega_dt",
                "ff_gear",
            ),
            non_negative=("hinge_offset_m", "slide_stiffness_N_m", "hinge_damping_Nms", "slide_damping_Ns_m"),
        )
        if len(self.bus_size_m) != 3 or any(not (np.isfinite(x) and x > 0) for x in self.bus_size_m):
            raise ValueError(f"bus_size_m: need three lengths > 0, got {self.bus_size_m!r}")
        if self.layout not in ("point_symmetric", "mirror"):
            raise ValueError(f"layout: must be 'point_symmetric' or 'mirror', got {self.layout!r}")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator: must be one of {sorted(INTEGRATORS)}, got {self.integrator!r}")

    # ------------------------------------------------------------ derived inertias
    @property
    def bus_inertia_kgm2(self) -> np.ndarray:
        """Principal inertia of the uniform bus box, ``m(b² + c²)/12`` etc. [kg m²]."""
        a, b, c = self.bus_size_m
        m = self.bus_mass_kg
        return np.array([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0

    @property
    def wing_inertia_cm_kgm2(self) -> np.ndarray:
        """Wing principal inertia about its centre (local X, Y, Z) [kg m²]."""
        m, l, w, t = self.wing_mass_kg, self.wing_length_m, self.wing_width_m, self.wing_thickness_m
        return np.array([m * (t * t + w * w), m * (l * l + w * w), m * (l * l + t * t)]) / 12.0

    @property
    def servo_omega_rad_s(self) -> float:
        """Servo bandwidth ``ω_s = servo_omega_dt / timestep`` [rad/s]."""
        return self.servo_omega_dt / self.timestep_s

    def servo_gains(self) -> dict[str, tuple[float, float]]:
        """``{joint: (k_p, k_d)}`` with ``k_p = J ω_s²``, ``k_d = 2 J ω_s`` (module docs)."""
        w = self.servo_omega_rad_s
        J_hinge = float(self.wing_inertia_cm_kgm2[2] + self.wing_mass_kg * (self.wing_length_m / 2) ** 2)
        J_slide = self.wing_mass_kg
        out = {}
        for j in SHAPE_JOINTS:
            J = J_hinge if j.endswith("bend") else J_slide
            out[j] = (J * w * w, 2.0 * J * w)
        return out


def build_msac_spec(params: MsacModelParams) -> mujoco.MjSpec:
    """Return the ``MjSpec`` of the MSAC spacecraft (see module docs)."""
    p = params
    spec = free_space_spec(
        name=p.name, timestep_s=p.timestep_s, integrator=p.integrator, solver_tolerance=p.solver_tolerance
    )
    reach = p.hinge_offset_m + 1.05 * p.wing_length_m
    set_view(spec, extent=2 * reach)

    wb = spec.worldbody
    wb.add_light(
        name="sun",
        pos=[0, 0, 4 * reach],
        dir=[0, 0, -1],
        type=int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL),
        diffuse=[0.8, 0.8, 0.8],
    )
    # fixed world reference marker (a bar along +X beyond the wing tips) for the videos
    wb.add_geom(
        name="world_marker",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.04 * reach, 0.01 * reach, 0.01 * reach],
        pos=[1.15 * reach, 0, 0],
        contype=0,
        conaffinity=0,
        rgba=list(MARKER_RGBA),
        group=2,
    )

    bus = wb.add_body(name="bus")
    bus.add_freejoint(name="bus_free")
    bus.explicitinertial = True
    bus.mass = p.bus_mass_kg
    bus.ipos = [0.0, 0.0, 0.0]
    bus.inertia = p.bus_inertia_kgm2.tolist()
    half = [x / 2 for x in p.bus_size_m]
    bus.add_geom(
        name="bus_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, contype=0, conaffinity=0, mass=0, rgba=list(BUS_RGBA)
    )
    # a small dish on +Y shows the bus's own rotation
    bus.add_geom(
        name="bus_tag",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.3 * half[0], 0.05 * half[1], 0],
        pos=[0.0, half[1] * 1.05, 0.0],
        quat=[np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0],
        contype=0,
        conaffinity=0,
        mass=0,
        rgba=[0.2, 0.2, 0.2, 1.0],
    )

    second_quat = [0.0, 0.0, 0.0, 1.0] if p.layout == "point_symmetric" else [0.0, 0.0, 1.0, 0.0]
    l, t, w = p.wing_length_m, p.wing_thickness_m, p.wing_width_m
    for k, (sign, quat) in enumerate(((1.0, [1.0, 0.0, 0.0, 0.0]), (-1.0, second_quat)), start=1):
        root = bus.add_body(name=f"w{k}_root", pos=[sign * p.hinge_offset_m, 0.0, 0.0], quat=quat)
        root.add_joint(name=f"w{k}_bend", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], damping=p.hinge_damping_Nms)
        root.explicitinertial = True
        root.mass = p.root_mass_kg
        root.ipos = [0.0, 0.0, 0.0]
        root.inertia = [p.root_inertia_kgm2] * 3
        wing = root.add_body(name=f"w{k}", pos=[0.0, 0.0, 0.0])
        wing.add_joint(
            name=f"w{k}_ext",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[1, 0, 0],
            stiffness=p.slide_stiffness_N_m,
            springref=0.0,
            damping=p.slide_damping_Ns_m,
        )
        wing.explicitinertial = True
        wing.mass = p.wing_mass_kg
        wing.ipos = [l / 2, 0.0, 0.0]
        wing.inertia = p.wing_inertia_cm_kgm2.tolist()
        wing.add_geom(
            name=f"w{k}_panel",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[l / 2, t / 2, w / 2],
            pos=[l / 2, 0.0, 0.0],
            contype=0,
            conaffinity=0,
            mass=0,
            rgba=list(WING_RGBA[k - 1]),
        )

    gains = p.servo_gains()
    for j in SHAPE_JOINTS:
        act = spec.add_actuator(name=f"{j}_ff", target=j, trntype=mujoco.mjtTrn.mjTRN_JOINT, group=0)
        act.set_to_motor()
        act.gear[0] = p.ff_gear
        act.ctrllimited = 0
        act.forcelimited = 0
    for j in SHAPE_JOINTS:
        kp, kd = gains[j]
        act = spec.add_actuator(name=f"{j}_servo", target=j, trntype=mujoco.mjtTrn.mjTRN_JOINT, group=1)
        act.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR
        act.actlimited = 0
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        act.gainprm[0] = kp
        act.biasprm[0:3] = [0.0, -kp, -kd]
        act.ctrllimited = 0
        act.forcelimited = 0

    spec.add_sensor(
        name="bus_angmom", type=mujoco.mjtSensor.mjSENS_SUBTREEANGMOM, objtype=mujoco.mjtObj.mjOBJ_BODY, objname="bus"
    )
    spec.add_sensor(
        name="bus_angvel", type=mujoco.mjtSensor.mjSENS_FRAMEANGVEL, objtype=mujoco.mjtObj.mjOBJ_BODY, objname="bus"
    )
    for j in SHAPE_JOINTS:
        spec.add_sensor(
            name=f"{j}_frc", type=mujoco.mjtSensor.mjSENS_JOINTACTFRC, objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=j
        )
    return spec


def shape_indices(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Index arrays of a compiled MSAC model.

    Returns ``qpos`` (4,) and ``dof`` (4,) addresses of the shape joints (order
    :data:`SHAPE_JOINTS`), ``bus_qpos`` (7,) and ``bus_dof`` (6,) of the free joint, ``ff`` and
    ``servo`` (4,) actuator indices, ``servo_act`` (4,) the servos' ``act`` addresses (their
    set-points), and the sensor address slices ``angmom`` (3,),
    ``angvel`` (3,), ``frc`` (4,).
    """
    jid = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in SHAPE_JOINTS]
    if min(jid) < 0:
        raise ValueError("model: not an MSAC model (shape joints missing)")
    free = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "bus_free")
    q0, v0 = model.jnt_qposadr[free], model.jnt_dofadr[free]

    def sens(name: str) -> np.ndarray:
        i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
        return model.sensor_adr[i] + np.arange(model.sensor_dim[i])

    act = lambda n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n)  # noqa: E731
    return {
        "qpos": model.jnt_qposadr[jid].astype(np.int64),
        "dof": model.jnt_dofadr[jid].astype(np.int64),
        "bus_qpos": q0 + np.arange(7),
        "bus_dof": v0 + np.arange(6),
        "ff": np.array([act(f"{j}_ff") for j in SHAPE_JOINTS]),
        "servo": np.array([act(f"{j}_servo") for j in SHAPE_JOINTS]),
        "servo_act": np.array([model.actuator_actadr[act(f"{j}_servo")] for j in SHAPE_JOINTS]),
        "angmom": sens("bus_angmom"),
        "angvel": sens("bus_angvel"),
        "frc": np.concatenate([sens(f"{j}_frc") for j in SHAPE_JOINTS]),
    }
