r"""The CNUSAIL-1 disturbance torques as one load, with the torque of each source kept apart.

Source: CNUSAIL spec §6 (paper Eqs. 12–23, errata E-6, E-10, E-11) and §4.3. The force models
are the project's environment loads; this wrapper only builds them for the cubesat and sums them:

* gravity gradient (§6.1, Eq. 12): :class:`~magsail_mj.loads.tidal.GravityGradientTorqueLoad`,
  T = 3μ/r³ û × (J û) with the composite inertia J of the current configuration;
* aerodynamic drag (§6.2, Eqs. 13–15): :class:`~magsail_mj.loads.drag.RigidDragLoad` on the facets
  of :func:`cubesat_drag_facets` — the sail as one two-sided plate of A_s at r_cp (area
  projected |ẑ_B·V̂|) plus, for ``"sail+bus"``, the six one-sided bus faces at their centroids;
  stowed: bus faces only;
* solar radiation pressure on the sail (§6.3, Eqs. 16–22): :class:`~magsail_mj.loads.srp.RigidSRPLoad`
  with McInnes' optical model (aluminised Kapton, :meth:`Optics.cnusail_sail`), zero in shadow;
  none when stowed (SRP on the bus is neglected, as in the paper);
* residual dipole (§6.4, Eq. 23): :class:`~magsail_mj.loads.dipole.ResidualDipoleLoad`, T = D × B.

Only torques are applied (``apply_force=False``): the world origin is the separately propagated
reference orbit, so the bus CM stays at the origin and the translational effect of drag and SRP
belongs to the lifetime analysis (§4.3, §10). Each source can be switched off.
"""

from __future__ import annotations

from typing import Literal

import mujoco
import numpy as np

from magsail_mj.environment.surfaces import FacetSet, Optics

from magsail_mj.loads.base import StepState
from magsail_mj.loads.dipole import ResidualDipoleLoad
from magsail_mj.loads.drag import RigidDragLoad
from magsail_mj.loads.srp import RigidSRPLoad
from magsail_mj.loads.tidal import GravityGradientTorqueLoad

__all__ = ["SOURCES", "cubesat_drag_facets", "cubesat_sail_facets", "CubesatDisturbanceLoad"]

SOURCES = ("gravity_gradient", "drag", "srp", "residual_dipole")
"""Names of the disturbance sources, in the order of :meth:`CubesatDisturbanceLoad.torques_body`."""


def cubesat_sail_facets(*, area_m2: float, r_cp_m, optics: Optics | None = None) -> FacetSet:
    """The sail: one two-sided plate of ``area_m2`` with normal +z_B at r_cp (body axes)."""
    return FacetSet.plate(area=area_m2, normal=(0.0, 0.0, 1.0), centre=tuple(r_cp_m),
                          optics=optics or Optics.cnusail_sail(), two_sided=True)


def cubesat_drag_facets(*, configuration: Literal["stowed", "deployed"], surfaces: Literal["sail+bus", "sail"],
                        sail_area_m2: float, r_cp_m, bus_size_m, bus_centroid_m) -> FacetSet:
    """Drag facets of spec §6.2: deployed ``"sail+bus"`` = sail plate + six bus faces; ``"sail"`` =
    the paper's single plate; stowed = the six bus faces whichever option."""
    bus = FacetSet.box(size=bus_size_m, centre=bus_centroid_m)
    if configuration == "stowed":
        return bus
    sail = cubesat_sail_facets(area_m2=sail_area_m2, r_cp_m=r_cp_m)
    return sail if surfaces == "sail" else FacetSet.concat([sail, bus])


def _cross(a, b) -> np.ndarray:
    """a × b of two 3-vectors (a fast path for the per-step loop; ``np.cross`` costs ~10 µs)."""
    return np.array((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))


class CubesatDisturbanceLoad:
    """Sum of the enabled disturbance torques on the bus (module docstring).

    Args:
      body_id: the bus body; inertia_kg_m2: composite inertia (3,) or (3, 3);
      drag_facets / srp_facets: facet sets (``None`` = source off);
      drag_coefficient: C_d; residual_dipole_A_m2: (3,) body-fixed D (``None`` or zero = off);
      gravity_gradient: include the gravity-gradient torque; mu: gravitational parameter.

    Per step the body → world rotation R is formed once and every source is evaluated in body
    axes with the force laws of the shared loads written out for this geometry
    (:func:`~magsail_mj.environment.gravity.gravity_gradient_torque`,
    :func:`~magsail_mj.environment.surfaces.drag_forces` as (Σ k_i c_i) × V, the sail's
    :func:`~magsail_mj.environment.surfaces.srp_forces` in scalar form, D × B); the result equals the
    world-axes project loads (:attr:`reference_loads`, tested to 1e-12 relative at random states)
    at a fraction of their per-step cost. The per-source torques of the latest state are cached,
    so a probe and :meth:`add` in the same step share one evaluation.
    """

    name = "cubesat_disturbances"

    def __init__(self, body_id: int, *, inertia_kg_m2, drag_facets: FacetSet | None, srp_facets: FacetSet | None,
                 drag_coefficient: float = 2.2, residual_dipole_A_m2=None, gravity_gradient: bool = True,
                 mu: float = 3.986004418e14) -> None:
        self.body_id = int(body_id)
        I = np.asarray(inertia_kg_m2, dtype=float)
        self.inertia = np.diag(I) if I.shape == (3,) else I
        self.mu = float(mu)
        self.gravity_gradient = bool(gravity_gradient)
        self.drag_facets = drag_facets
        self.srp_facets = srp_facets
        self.cd = float(drag_coefficient)
        D = None if residual_dipole_A_m2 is None else np.asarray(residual_dipole_A_m2, dtype=float)
        self.dipole = D if D is not None and np.any(D) else None
        self._drag = None
        if drag_facets is not None:
            # per facet: −½ C_d A_i (centre_i), used as  T = (Σ_i k_i proj_i c_i) × V
            self._drag = (drag_facets.normal.copy(), (-0.5 * self.cd * drag_facets.area)[:, None] * drag_facets.centre,
                          drag_facets.two_sided.copy())
        self._sail = None
        if srp_facets is not None:
            if len(srp_facets) != 1 or not srp_facets.two_sided[0] or not np.allclose(srp_facets.normal[0], [0, 0, 1]):
                raise ValueError("srp_facets: the fast path takes one two-sided plate with normal +z "
                                 f"(the sail), got {len(srp_facets)} facets")
            self._sail = srp_facets
        self._key: tuple | None = None
        self._torques = np.zeros((4, 3))
        self._R = np.zeros(9)  # scratch for mju_quat2Mat; zeros keep every build identical

    @property
    def reference_loads(self) -> list:
        """The equivalent world-axes project loads (GravityGradientTorqueLoad, RigidDragLoad,
        RigidSRPLoad, ResidualDipoleLoad), for cross-checks."""
        out: list = []
        if self.gravity_gradient:
            out.append(GravityGradientTorqueLoad(self.body_id, self.inertia, mu=self.mu))
        if self.drag_facets is not None:
            out.append(RigidDragLoad(self.body_id, self.drag_facets, drag_coefficient=self.cd, apply_force=False))
        if self.srp_facets is not None:
            out.append(RigidSRPLoad(self.body_id, self.srp_facets, apply_force=False))
        if self.dipole is not None:
            out.append(ResidualDipoleLoad(self.body_id, self.dipole))
        return out

    def rotation(self, state: StepState) -> np.ndarray:
        """Body → world rotation matrix of the bus at ``state``."""
        mujoco.mju_quat2Mat(self._R, state.xquat[self.body_id])
        return self._R.reshape(3, 3).copy()

    def torques_body(self, state: StepState) -> np.ndarray:
        """(4, 3) body-frame torques [N m] of the sources in :data:`SOURCES` order (zeros when off)."""
        key = (id(state), state.t)
        if key == self._key:
            return self._torques
        env = state.env
        R = self.rotation(state)
        out = np.zeros((4, 3))
        if self.gravity_gradient:
            r_b = (env.r_ref_eci + state.pos[self.body_id]) @ R
            rn = float(np.sqrt(r_b @ r_b))
            u = r_b / rn
            out[0] = (3.0 * self.mu / rn**3) * _cross(u, self.inertia @ u)
        if self._drag is not None and env.density_kg_m3 > 0.0:
            out[1] = self._drag_torque((env.v_rel_eci + state.vel[self.body_id]) @ R, env.density_kg_m3)
        if self._sail is not None and env.srp_pressure_N_m2 > 0.0:
            out[2] = self._sail_srp_torque(env.sun_eci @ R, env.srp_pressure_N_m2)
        if self.dipole is not None:
            out[3] = _cross(self.dipole, env.B_eci @ R)
        self._key = (id(state), state.t)
        self._torques = out
        self._last_R = R
        return out

    def _drag_torque(self, V: np.ndarray, rho: float) -> np.ndarray:
        """Σ_i c_i × F_i with F_i = −½ C_d ρ A_i |n̂_i·V| V (two-sided) or max(n̂_i·V, 0) (one-sided),
        i.e. (Σ_i −½ C_d A_i proj_i c_i) ρ × V — the law of :func:`drag_forces` (body axes)."""
        normal, kc, two = self._drag
        proj = normal @ V
        proj = np.where(two, np.abs(proj), np.maximum(proj, 0.0))
        lever = rho * (proj @ kc)
        return _cross(lever, V)

    def _sail_srp_torque(self, s: np.ndarray, P: float) -> np.ndarray:
        """r_cp × F of the sail (one two-sided plate, normal +z_B) with the law of :func:`srp_forces`:
        F = −P A cos α [(1 − r s) ŝ + (2 r s cos α + B_l r (1 − s) + (1 − r) κ) n̂_l] (scalar form)."""
        f = self._sail
        o = f.optics[0]
        c = float(s[2])
        front = c >= 0.0
        cos_a = abs(c)
        if front or not o.swap_back:
            B_l, B_d, e_l, e_d = o.B_f, o.B_b, o.e_f, o.e_b
        else:
            B_l, B_d, e_l, e_d = o.B_b, o.B_f, o.e_b, o.e_f
        esum = e_l + e_d
        kappa = (e_l * B_l - e_d * B_d) / esum if esum > 0 else 0.0
        rs = o.r * o.s
        k_n = (2.0 * rs * cos_a + B_l * o.r * (1.0 - o.s) + (1.0 - o.r) * kappa) * (1.0 if front else -1.0)
        scale = -P * float(f.area[0]) * cos_a
        F = scale * (1.0 - rs) * s
        F[2] += scale * k_n
        return _cross(f.centre[0], F)

    def torques_world(self, state: StepState) -> np.ndarray:
        """(4, 3) world-frame torques [N m] (rows: :data:`SOURCES`)."""
        T = self.torques_body(state)
        return T @ self._last_R.T

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        T = self.torques_body(state).sum(axis=0)
        xfrc[self.body_id, 3:] += self._last_R @ T
