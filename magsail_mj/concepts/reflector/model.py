r"""Model builder of the reflector concept: config → coil geometry → MjSpec, and the parts a task
assembles (controllers, orbit, initial state).

A rigid square plate (:mod:`magsail_mj.concepts.reflector.mjcf`) whose truss carries two serpentine coils and an
in-plane loop (:mod:`magsail_mj.geometry.reflector_coil`); each path acts as an ideal dipole along
its axis limited to ``m_max = T_max / B_ref`` (Robb et al. 2020, Eqs. 1–4; ``T_max`` from
:mod:`magsail_mj.analysis.coil_torque`). Frames: body = plate principal axes (z = plate normal);
world = inertial (Scenario A) or the paper's xyz orbit frame (Scenario B). Quaternions scalar-first,
body → world.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import mujoco
import numpy as np

from magsail_mj.analysis.coil_torque import capability, loop_side_for_capability
from magsail_mj.concepts.reflector.bdot import PlateBdotController
from magsail_mj.control.reflector_pitch import ReflectorPitchController, pitch_gains
from magsail_mj.control.reflector_steering import ReflectorOrbit, SteeringReference
from magsail_mj.geometry.reflector_coil import CoilPath, coil_x, coil_y
from magsail_mj.concepts.reflector.mjcf import MarkerSpec, PlateModelParams, build_plate_spec, plate_indices
from magsail_mj.concepts.reflector.config import ReflectorConfig

__all__ = ["ASSUMPTIONS", "CoilCapability", "coil_capability", "ReflectorModel", "DETUMBLE_MARKERS", "PITCH_MARKERS"]

ASSUMPTIONS = {
    "A1": "lattice depth h = L (one cell deep)",
    "A2": "coil columns one cell wide every other cell column (p = 2), d/L three-quarter turns per column, "
    "same circulation in every column, connectors along +x",
    "A3": "in-plane loop: the lattice-aligned centred square whose capability is closest to the coil path's",
    "A4": "R_e = 6371 km (mean radius)",
    "A5": "ground point rotates at the solar-day rate 2π/86400 s⁻¹ in the Sun-fixed frame",
    "A6": "detumbling field fixed in inertial space along the initial plate normal (+Z)",
    "A7": "pitch about the principal in-plane body axis y = world y (Sun line = orbit normal)",
    "Eq8": "Eq. 8 taken as the commanded dipole m = k ω × B_b (printed torque form does no work)",
    "omega0": "initial rate magnitude 0.1 rad/s, ω0 = (0.1/√2)(1, 1, 0) (printed vector has magnitude 1)",
    "Eq12": "branch jumps of Eq. 12 removed by unwrapping ε = atan2(a, b)",
    "q_err": "body-frame q_e = q_ref* ⊗ q_t, torque −P_q q_e,vec − P_ω ω (restoring)",
    "beta_ref": "reference pitch β_ref = π/2 − ψ_c about +y, body x = grey line",
    "s_path": "positive path current gives a dipole along the path's +axis (y-coil as generated: s_path = −1)",
    "zoh": "controllers run every integration step with zero-order hold; Scenario A world inertial without "
    "orbit; Scenario B world axes = the paper's xyz frame",
    "inertia": "in-plane moments carry the thickness t (default h): I1 = I2 = m(d² + t²)/12 (MuJoCo triangle "
    "inequality), I3 = m d²/6",
}

DETUMBLE_MARKERS: tuple[MarkerSpec, ...] = (
    MarkerSpec("mk_field", (0.9, 0.2, 0.9, 1.0)),
    MarkerSpec("mk_omega", (0.1, 0.9, 0.2, 1.0)),
    MarkerSpec("mk_torque", (0.95, 0.15, 0.1, 1.0), length_rel=0.6),
)
"""Marker bodies of a detumble run: field, body rate, torque."""

PITCH_MARKERS: tuple[MarkerSpec, ...] = (
    MarkerSpec("mk_sun", (1.0, 0.85, 0.1, 1.0)),
    MarkerSpec("mk_ground", (0.2, 0.5, 1.0, 1.0)),
    MarkerSpec("mk_field", (0.9, 0.2, 0.9, 1.0), length_rel=0.6),
    MarkerSpec("mk_ref_line", (1.0, 1.0, 1.0, 1.0), kind="line", length_rel=0.65),
)
"""Marker bodies of a pitch run: Sun line, ground point, field, reference grey line."""


@dataclass(frozen=True)
class CoilCapability:
    """Geometric actuator figures of a config (Robb et al. 2020, Eqs. 1–4): ``T_max`` of the coil paths and the in-plane
    loop [N m], its side [m], the per-path dipole limits [A m²] and the cap used by the controller."""

    T_max_ycoil_Nm: float
    T_max_xcoil_Nm: float
    T_max_zloop_Nm: float
    zloop_side_m: float
    m_max_Am2: np.ndarray
    cap_Nm: float

    def as_dict(self) -> dict[str, float | list[float]]:
        """The figures as a JSON-ready dict (manifest ``coil_capability``)."""
        return {
            "T_max_ycoil_Nm": self.T_max_ycoil_Nm,
            "T_max_xcoil_Nm": self.T_max_xcoil_Nm,
            "T_max_zloop_Nm": self.T_max_zloop_Nm,
            "zloop_side_m": self.zloop_side_m,
            "m_max_Am2": self.m_max_Am2.tolist(),
            "cap_Nm": self.cap_Nm,
        }


def coil_capability(cfg: ReflectorConfig) -> CoilCapability:
    """Capability of the config's coil paths at ``coil.I_max_A``, ``coil.B_ref_T``:
    ``T_max = max over field directions of |Σ_i I l_i × B|`` per path, ``m_max = T_max / B_ref``."""
    p, c = cfg.plate, cfg.coil
    kw = dict(current_A=c.I_max_A, field_T=c.B_ref_T)
    y = CoilPath("ycoil", coil_y(p.side_m, p.cell_m, p.depth, p=c.pitch_cells, n_row=c.rows), axis=1, s_path=-1)
    x = CoilPath("xcoil", coil_x(p.side_m, p.cell_m, p.depth, p=c.pitch_cells, n_row=c.rows), axis=0, s_path=1)
    Ty, Tx = capability(y, **kw), capability(x, **kw)
    side, Tz = loop_side_for_capability(Ty, side_m=p.side_m, segment_m=p.cell_m, depth_m=p.depth, **kw)
    m_max = np.array([Tx, Ty, Tz]) / c.B_ref_T
    return CoilCapability(
        T_max_ycoil_Nm=Ty,
        T_max_xcoil_Nm=Tx,
        T_max_zloop_Nm=Tz,
        zloop_side_m=side,
        m_max_Am2=m_max,
        cap_Nm=cfg.control.cap_Nm or Ty,
    )


@dataclass
class ReflectorModel:
    """The built plate of a config: coil capability ``cap``, model parameters ``params``, the
    MjSpec ``spec`` and its compiled ``model``, indices ``idx``, mass [kg] and principal inertia
    ``inertia`` [kg m²] (body axes), and the orbit of Scenario B (``orbit``, built on first use)."""

    cfg: ReflectorConfig
    markers: tuple[MarkerSpec, ...] = ()
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        cfg = self.cfg
        self.cap = coil_capability(cfg)
        self.params = PlateModelParams(
            side_m=cfg.plate.side_m,
            cell_m=cfg.plate.cell_m,
            depth_m=cfg.plate.depth_m,
            areal_density_kg_m2=cfg.plate.areal_density_kg_m2,
            inertia_thickness_m=cfg.plate.inertia_thickness_m,
            coil_pitch_cells=cfg.coil.pitch_cells,
            zloop_side_m=self.cap.zloop_side_m,
            timestep_s=cfg.sim.timestep_s,
            integrator=cfg.sim.integrator,
            solver_tolerance=cfg.sim.solver_tolerance,
            markers=self.markers,
            name=f"reflector_{cfg.scenario.replace('/', '_')}",
        )
        self.spec = build_plate_spec(self.params)
        self.model = self.spec.compile()
        self.idx = plate_indices(self.model)
        self.mass_kg, self.inertia = self.params.mass_properties()

    @cached_property
    def orbit(self) -> ReflectorOrbit:
        """Scenario B orbit (Robb et al. 2020, Table 1) of ``[orbit]`` and ``field.B0_T``."""
        o = self.cfg.orbit
        return ReflectorOrbit.from_altitude(
            altitude_m=o.altitude_km * 1e3,
            R_e_m=o.R_e_km * 1e3,
            mu_m3_s2=o.mu_m3_s2,
            omega_e_rad_s=o.omega_e_rad_s,
            n_orbits=o.n_orbits,
            B0_T=self.cfg.field.B0_T,
        )

    @property
    def B_magnitude_T(self) -> float:
        """|B| of the constant-field cases [T]: ``field.magnitude_T``, else ``coil.B_ref_T``."""
        return self.cfg.field.magnitude_T or self.cfg.coil.B_ref_T

    def field_body_fn(self) -> Callable[[float, np.ndarray], np.ndarray]:
        """``(t, R) → B_b`` of the constant-field cases: ``B_b = Rᵀ B`` for an inertial field,
        ``B_b = B`` for a body-fixed one (``R`` body → world)."""
        B = self.B_magnitude_T * np.asarray(self.cfg.field.direction, dtype=float)
        if self.cfg.field.frame == "body":
            return lambda t, R: B.copy()
        return lambda t, R: R.T @ B

    def bdot_gain(self) -> float:
        """B-dot gain k [A m² s / T²] from ``control.omega_k_rad_s``."""
        return PlateBdotController.gain_from_omega_k(
            m_max_Am2=self.cap.m_max_Am2[1],
            B_ref_T=self.cfg.coil.B_ref_T,
            omega_k_rad_s=self.cfg.control.omega_k_rad_s,
        )

    def bdot_controller(self) -> PlateBdotController:
        """The Scenario A B-dot controller, every integration step."""
        cfg, c = self.cfg, self.cfg.control
        return PlateBdotController(
            law=c.law,
            m_max_Am2=self.cap.m_max_Am2[1],
            T_max_Nm=self.cap.cap_Nm,
            gain=self.bdot_gain(),
            I_max_A=cfg.coil.I_max_A,
            field_body=self.field_body_fn(),
            body_id=self.idx.plate,
            period_s=cfg.sim.timestep_s,
        )

    def pitch_controller(self) -> ReflectorPitchController:
        """The Scenario B quaternion-feedback controller, every integration step."""
        cfg, c = self.cfg, self.cfg.control
        return ReflectorPitchController(
            orbit=self.orbit,
            inertia_kgm2=self.inertia,
            omega_n_rad_s=c.omega_n_rad_s,
            zeta=c.zeta,
            rate_term=c.rate_term,
            feedforward=c.feedforward,
            saturation=c.saturation_mode,
            cap_Nm=self.cap.cap_Nm,
            B_ref_T=cfg.coil.B_ref_T,
            m_max_Am2=self.cap.m_max_Am2,
            body_id=self.idx.plate,
            period_s=cfg.sim.timestep_s,
        )

    def pitch_gains(self) -> tuple[np.ndarray, np.ndarray]:
        """``(P_q [N m], P_ω [N m s])`` of the pitch controller."""
        c = self.cfg.control
        return pitch_gains(self.inertia, omega_n_rad_s=c.omega_n_rad_s, zeta=c.zeta)

    def pitch_initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(q_ref(0), ω_ref(0) = −ψ̇(0) ŷ)`` [rad/s, body axes]: Scenario B starts on the reference."""
        ref = SteeringReference(self.orbit).at(0.0)
        return ref.q_ref, np.array([0.0, -ref.psi_dot, 0.0])

    def qpos_rows(self, q0: np.ndarray, n: int) -> np.ndarray:
        """``n`` copies of the initial ``qpos``: plate attitude ``q0``, markers at identity."""
        qpos = np.zeros((n, self.model.nq))
        qpos[:, self.idx.q_quat] = q0
        for qa in self.idx.marker_qpos.values():
            qpos[:, qa] = 1.0
        return qpos

    def write_state(self, data: mujoco.MjData, q0: np.ndarray, w0: np.ndarray) -> None:
        """Set ``data`` to attitude ``q0`` and body rate ``w0`` [rad/s], at rest otherwise, markers at identity."""
        data.qpos[:] = self.qpos_rows(q0, 1)[0]
        data.qvel[:] = 0.0
        data.qvel[self.idx.v_ang] = w0
