r"""Model builder of the CNUSAIL concept: config → cubesat MJCF (:mod:`magsail_mj.concepts.cnusail.mjcf`),
environment, disturbance load, flight controller and initial state.

Frames: world = ECI axes (origin on the reference orbit); body frame of Yoo et al. 2016 (ẑ_B = sail
normal); quaternions scalar-first, body → world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from magsail_mj.concepts.cnusail.modes import (
    CnusailControlParams,
    CnusailController,
    Mode,
    ModeLogicParams,
    command_quaternion,
)
from magsail_mj.concepts.cnusail.eigenaxis import orbital_rate, rate_error
from magsail_mj.control.detumble_laws import avanzini_giulietti_gain, geomagnetic_inclination_rad
from magsail_mj.environment.environment import Environment
from magsail_mj.environment.field import igrf_dipole
from magsail_mj.environment.timeutil import parse_epoch
from magsail_mj.loads.actuators_cubesat import RPM, MagnetorquerCycle, WheelDriver
from magsail_mj.concepts.cnusail.disturbances import CubesatDisturbanceLoad, cubesat_drag_facets, cubesat_sail_facets
from magsail_mj.concepts.cnusail.mjcf import CubesatModelParams, build_cubesat_spec, cubesat_indices
from magsail_mj.quaternion import quat_mul
from magsail_mj.concepts.cnusail.config import CnusailConfig

__all__ = ["CnusailModel", "model_params", "DEG", "bcross_gain_of"]

DEG = math.pi / 180.0


def model_params(cfg: CnusailConfig) -> CubesatModelParams:
    """MJCF parameters of the cubesat of ``cfg`` (bus, sail, three wheel rotors, markers)."""
    sc, w = cfg.spacecraft, cfg.actuators.wheels
    return CubesatModelParams(
        configuration=sc.configuration,
        mass_kg=sc.mass_kg,
        inertia_kgm2=tuple(sc.inertia),
        bus_size_m=tuple(sc.bus_size_m),
        bus_centroid_m=tuple(sc.bus_centroid),
        sail_side_m=sc.sail_side_m,
        sail_centre_m=tuple(sc.r_cp_m),
        rotor_mass_kg=w.rotor_mass_kg,
        rotor_spin_inertia_kgm2=w.rotor_inertia_kgm2,
        rotor_transverse_inertia_kgm2=w.rotor_transverse_inertia_kgm2,
        wheel_damping_Nms=w.K_B_Nms,
        motor_force_limit_Nm=10.0 * w.torque_max_Nm,
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        solver_tolerance=cfg.sim.solver_tolerance,
        markers=cfg.render.markers,
        name=f"cnusail_{cfg.scenario}",
    )


def bcross_gain_of(cfg: CnusailConfig, environment: Environment) -> float:
    """The B×ω detumble gain k [N m s] of ``cfg``: ``control.bcross_gain_Nms`` when given, else
    Avanzini & Giulietti's ``2 n (1 + sin ξ_m) J_min``
    (:func:`~magsail_mj.control.detumble_laws.avanzini_giulietti_gain`) with n the mean motion of the
    epoch elements, J_min the smallest of ``spacecraft.inertia`` (principal axes) and ξ_m the
    inclination of the epoch's orbit plane (r × v of the reference orbit at t = 0)
    to the magnetic equator at the epoch: of the IGRF degree-1 dipole (field date) turned from ECEF
    into ECI by the epoch's sidereal angle for ``igrf`` and ``tilted_dipole``, of the rotation axis
    for the aligned models and for a field without a dipole (``constant``, ``none``)."""
    given = cfg.control.bcross_gain_Nms
    if given is not None:
        return float(given)
    env0 = environment.sample(0.0)
    axis = np.array([0.0, 0.0, 1.0])
    if cfg.field.model in ("igrf", "tilted_dipole"):
        date = parse_epoch(cfg.field.igrf_date) if cfg.field.igrf_date else environment.epoch
        m_ecef = igrf_dipole(date)[0]
        c, s = math.cos(env0.gmst_rad), math.sin(env0.gmst_rad)  # ECEF = R3(θ) ECI
        axis = np.array([c * m_ecef[0] - s * m_ecef[1], s * m_ecef[0] + c * m_ecef[1], m_ecef[2]])
    xi_m = geomagnetic_inclination_rad(env0.r_ref_eci, env0.v_ref_eci, axis)
    return avanzini_giulietti_gain(
        mean_motion_rad_s=environment.elements.mean_motion(environment.mu),
        xi_m_rad=xi_m,
        J_min_kgm2=float(min(cfg.spacecraft.inertia)),
    )


@dataclass
class CnusailModel:
    """The built cubesat of an attitude config: ``params``, the MjSpec ``spec`` and its compiled
    ``model``, indices ``idx``, the environment (J2 reference orbit, field, atmosphere, Sun) and its
    period ``orbit_period_s`` [s], the composite principal inertia ``inertia`` [kg m², body axes]
    and the disturbance load ``disturbances`` (gravity gradient, drag, SRP, residual dipole)."""

    cfg: CnusailConfig
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        self.params = model_params(self.cfg)
        self.spec = build_cubesat_spec(self.params)
        self.model = self.spec.compile()
        self.idx = cubesat_indices(self.model)
        self.environment = Environment.from_config(self.cfg.environment_config(), duration_s=self.cfg.sim.duration_s)
        el = self.environment.elements
        self.orbit_period_s = el.period(self.environment.mu)
        self.inertia = np.diag(np.asarray(self.cfg.spacecraft.inertia, dtype=float))
        self.disturbances = self.make_disturbances()

    def make_disturbances(self) -> CubesatDisturbanceLoad:
        """Disturbance torques (Yoo et al. 2016, Eqs. 12–23) on the bus (``drag``, ``srp`` deployed only,
        gravity gradient)."""
        cfg, sc = self.cfg, self.cfg.spacecraft
        drag = None
        if cfg.drag.enabled:
            drag = cubesat_drag_facets(
                configuration=sc.configuration,
                surfaces=sc.drag_surfaces,
                sail_area_m2=sc.sail_area_m2,
                r_cp_m=sc.r_cp_m,
                bus_size_m=sc.bus_size_m,
                bus_centroid_m=sc.bus_centroid,
            )
        srp = None
        if cfg.srp.enabled and sc.configuration == "deployed":
            srp = cubesat_sail_facets(area_m2=sc.sail_area_m2, r_cp_m=sc.r_cp_m)
        return CubesatDisturbanceLoad(
            self.idx.bus,
            inertia_kgm2=self.inertia,
            drag_facets=drag,
            srp_facets=srp,
            drag_coefficient=cfg.drag.drag_coefficient,
            residual_dipole_Am2=np.asarray(sc.residual_dipole_Am2),
            gravity_gradient=cfg.gravity.classical_torque,
            mu=self.environment.mu,
        )

    def make_controller(self) -> CnusailController:
        """The flight controller (B-dot, eigen-axis or PD, unloading, mode logic)."""
        cfg, c, a = self.cfg, self.cfg.control, self.cfg.actuators
        driver = WheelDriver(a.wheels.motor_params(), model=a.wheels.model, electrical=a.wheels.electrical)
        modes = ModeLogicParams(
            enabled=c.modes.enabled,
            detumble_entry_rad_s=c.modes.detumble_entry_deg_s * DEG,
            detumble_exit_rad_s=c.modes.detumble_exit_deg_s * DEG,
            dwell_s=c.modes.dwell_s,
            deorbit_at_s=c.modes.deorbit_at_s,
        )
        params = CnusailControlParams(
            timestep_s=cfg.sim.timestep_s,
            law=c.mode,
            command=c.command,
            attitude_period_s=1.0 / c.rate_Hz,
            mtq_cycle=MagnetorquerCycle(cycle_s=a.mtq.cycle_s, blank_s=a.mtq.blank_s, timestep_s=cfg.sim.timestep_s),
            mtq_limits_Am2=a.mtq.limit_vector,
            bdot_form=c.bdot_form,
            bdot_gain=c.bdot_gain_Am2s_T,
            bdot_normalised_gain_Am2s=c.bdot_normalised_gain_Am2s,
            bdot_omega_c_rad_s=c.bdot_omega_c_rad_s,
            bdot_law=c.bdot_law,
            bdot_law_params=c.bdot_law_params,
            bcross_gain_Nms=bcross_gain_of(cfg, self.environment) if c.bdot_law == "b_cross" else 1.0,
            nonmonotonic_gain_per_Nms=c.nonmonotonic_gain_per_Nms,
            nonmonotonic_alpha=c.nonmonotonic_alpha,
            nonmonotonic_lookahead_s=c.nonmonotonic_lookahead_s,
            nonmonotonic_field_ahead=c.nonmonotonic_field_ahead,
            omega_n_rad_s=c.omega_n_rad_s,
            zeta=c.zeta,
            rate_max_rad_s=c.slew_rate_max_deg_s * DEG,
            clamp_min=c.gain_clamp_min,
            gyro_comp=c.gyro_comp,
            shortest_rotation=c.shortest_rotation,
            recalc_enabled=c.gain_recalc,
            recalc_margin_rad=c.recalc_margin_deg * DEG,
            unloading_enabled=c.unloading.enabled,
            k_rw_per_s=c.unloading.k_rw_per_s,
            unload_on_rpm=c.unloading.threshold_rpm,
            unload_off_rpm=c.unloading.off_rpm,
            inertia_kgm2=self.inertia,
            wheel_driver=driver,
            modes=modes,
            magnetometer_noise_T=c.sensors.magnetometer_noise_T,
            gyro_noise_rad_s=c.sensors.gyro_noise_rad_s,
            seed=cfg.sim.seed,
        )
        idx = self.idx
        return CnusailController(
            params,
            q_quat=idx.q_quat,
            v_ang=idx.v_ang,
            wheel_qvel=idx.wheel_qvel,
            wheel_act=idx.wheel_act,
            environment=self.environment,
        )

    def initial_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p_b (4,), ω_body (3,) [rad/s], ω_M (3,) [rad/s]) at t = 0:
        p_b = p_c ⊗ p_e with p_c the initial command (nadir for detumbling), and ω from
        ``initial.omega0_deg_s`` or from ω_e(0) = 0."""
        c = self.cfg.control
        env0 = self.environment.sample(0.0)
        mode = Mode.DEORBIT if (c.mode != "bdot" and c.command == "deorbit" and not c.modes.enabled) else Mode.NADIR
        p_c = command_quaternion(mode, env0.r_ref_eci, env0.v_ref_eci)
        p_e = np.asarray(self.cfg.initial.q_err0_wxyz, dtype=float)
        p_b = quat_mul(p_c, p_e)
        p_b = p_b / np.linalg.norm(p_b)
        if self.cfg.initial.omega0_deg_s is not None:
            w = np.asarray(self.cfg.initial.omega0_deg_s, dtype=float) * DEG
        else:
            w = -rate_error(np.zeros(3), p_e, orbital_rate(env0.r_ref_eci, env0.v_ref_eci))
        return p_b, w, np.asarray(self.cfg.initial.wheel_speed_rpm, dtype=float) * RPM

    def init_state(self, data: mujoco.MjData) -> None:
        """Write :meth:`initial_state` into ``data`` (at the world origin, markers at identity)."""
        p_b, w, wM = self.initial_state()
        idx = self.idx
        data.qpos[idx.q_pos] = 0.0
        data.qpos[idx.q_quat] = p_b
        data.qvel[idx.v_lin] = 0.0
        data.qvel[idx.v_ang] = w
        data.qvel[idx.wheel_qvel] = wM
        for qa in idx.marker_qpos.values():
            data.qpos[qa : qa + 4] = [1.0, 0.0, 0.0, 0.0]
