r"""Model builder of the MSAC concept: config → model parameters → MjSpec
(:mod:`magsail_mj.concepts.msac.mjcf`), the cycle path, the exact planar model and the analytic
references (Eq. 6/7 and the exact model).

Frames: the MuJoCo world is inertial (free space, gravity off, no orbit). The bus yaw ``ψ``
is about world Z; the wing angle ``φ`` is the hinge angle relative to the bus; ``s`` the slide of
the whole rigid wing. Units SI.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from magsail_mj.concepts.msac.reference import PlanarMsac, exact_rotation_path, lumped_theta, wing_inertias
from magsail_mj.concepts.msac.cycle import cycle_state
from magsail_mj.concepts.msac.mjcf import MsacModelParams, build_msac_spec
from magsail_mj.concepts.msac.config import MsacConfig, make_path

__all__ = ["MsacModel", "make_params", "planar_model"]


def make_params(cfg: MsacConfig) -> MsacModelParams:
    """Model parameters of a config (wing mass = areal density × ℓ × w)."""
    w = cfg.wings
    return MsacModelParams(
        bus_mass_kg=cfg.bus.mass_kg,
        bus_size_m=tuple(cfg.bus.size_m),
        wing_length_m=w.length_m,
        wing_width_m=w.width_m,
        wing_thickness_m=w.thickness_m,
        wing_mass_kg=w.areal_density_kg_m2 * w.length_m * w.width_m,
        hinge_offset_m=w.hinge_offset_m,
        layout=w.layout,
        root_mass_kg=w.root_mass_kg,
        root_inertia_kgm2=w.root_inertia_kgm2,
        slide_stiffness_N_m=w.slide_stiffness_N_m,
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        solver_tolerance=cfg.sim.solver_tolerance,
        servo_omega_dt=cfg.drive.servo_omega_dt,
        name=f"msac_{cfg.scenario}",
    )


def planar_model(params: MsacModelParams, *, inertia_scale: float = 1.0) -> PlanarMsac:
    """The exact planar model with the MJCF's own inertias (incl. hinge bodies)."""
    return PlanarMsac(
        bus_izz_kgm2=float(params.bus_inertia_kgm2[2]) * inertia_scale,
        wing_mass_kg=params.wing_mass_kg,
        wing_length_m=params.wing_length_m,
        wing_icm_kgm2=float(params.wing_inertia_cm_kgm2[2]),
        hinge_offset_m=params.hinge_offset_m,
        n_wings=2,
        root_mass_kg=params.root_mass_kg,
        root_inertia_kgm2=params.root_inertia_kgm2,
    )


@dataclass
class MsacModel:
    """The built MSAC of a config: model parameters ``params``, the cycle ``path``, the MjSpec
    ``spec`` (bus inertia scaled by ``bus.inertia_scale``) and its compiled ``model``, and the exact
    planar model ``planar`` with the same inertias."""

    cfg: MsacConfig
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        cfg = self.cfg
        self.params = make_params(cfg)
        self.path = make_path(cfg)
        self.spec = build_msac_spec(self.params)
        scale = cfg.bus.inertia_scale
        if scale != 1.0:
            b = self.spec.body("bus")
            b.inertia = (self.params.bus_inertia_kgm2 * scale).tolist()
        self.model = self.spec.compile()
        self.planar = planar_model(self.params, inertia_scale=scale)

    def references(self) -> dict[str, float]:
        """Analytic summary entries: inertias, Eq. (6)/(7) and the exact model."""
        cfg, P, path = self.cfg, self.planar, self.path
        wi = wing_inertias(P, s_e_m=path.s_e_m, s_c_m=path.s_c_m)
        theta_eq6 = lumped_theta(
            I_e=2 * wi.e_hinge, I_c=2 * wi.c_hinge, I_sat=P.bus_izz_kgm2, phi_a=path.phi_a_rad, phi_b=path.phi_b_rad
        )
        theta_str = lumped_theta(
            I_e=2 * wi.e_stretch,
            I_c=2 * wi.c_stretch,
            I_sat=P.bus_izz_kgm2,
            phi_a=path.phi_a_rad,
            phi_b=path.phi_b_rad,
        )
        # Eq. (6) is written for the MSAC loop; the other test paths follow from it: the reversed
        # loop flips the sign (T3), a reciprocal path or mirror-symmetric wings give zero (T2, T4)
        sign = {"msac": 1.0, "reversed": -1.0, "bend_only": 0.0, "extend_only": 0.0}[cfg.cycle.pattern]
        if cfg.wings.layout == "mirror":
            sign = 0.0
        theta_eq6, theta_str = sign * theta_eq6, sign * theta_str
        # the exact model holds for point-symmetric wings; mirror wings give zero by symmetry
        exact = 0.0 if cfg.wings.layout == "mirror" else float(exact_rotation_path(P, path.waypoints).sum())
        T = path.period_s
        # momentum scale: the largest shape angular momentum |N_φ φ̇ + N_s ṡ| along the path
        tt = np.linspace(0.0, T, 2001)
        st = cycle_state(path, tt)
        n_phi, n_s = P.shape_momentum_coefficients(st.phi, st.s)
        L_scale = float(np.max(np.abs(n_phi * st.phi_dot + n_s * st.s_dot)))
        return {
            "bus_mass_kg": cfg.bus.mass_kg,
            "bus_izz_kgm2": P.bus_izz_kgm2,
            "wing_mass_kg": P.wing_mass_kg,
            "wing_I_rest_hinge_kgm2": wi.rest_hinge,
            "wing_I_e_hinge_kgm2": wi.e_hinge,
            "wing_I_c_hinge_kgm2": wi.c_hinge,
            "wing_I_rest_centre_kgm2": wi.rest_centre,
            "wing_I_e_centre_kgm2": wi.e_centre,
            "wing_I_c_centre_kgm2": wi.c_centre,
            "wing_I_e_stretch_kgm2": wi.e_stretch,
            "wing_I_c_stretch_kgm2": wi.c_stretch,
            "extension_model": cfg.wings.extension_model,
            "cycle_frequency_Hz": cfg.cycle.frequency_Hz,
            "cycle_period_s": T,
            "stroke_rad": path.phi_a_rad - path.phi_b_rad,
            "theta_gamma_eq6_model_rad": theta_eq6,
            "theta_gamma_eq6_stretch_rad": theta_str,
            "omega_gamma_eq7_rad_s": theta_eq6 / T,
            "theta_gamma_exact_rad": exact,
            "omega_gamma_exact_rad_s": exact / T,
            "predicted_rate_lumped_rad_s": theta_eq6 / T,
            "predicted_rate_exact_rad_s": exact / T,
            "angmom_scale_Nms": L_scale,
        }
