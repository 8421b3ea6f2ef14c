r"""The CNUSAIL-1 disturbance torques as one load, with the torque of each source kept apart.

Source: Yoo et al. 2016, Eqs. 12–23, with the misprints corrected in the loads. The force models
are the project's environment loads; this wrapper only builds them for the cubesat and sums them:

* gravity gradient (Eq. 12): :class:`~magsail_mj.loads.tidal.GravityGradientTorqueLoad`,
  T = 3μ/r³ û × (J û) with the composite inertia J of the current configuration;
* aerodynamic drag (Eqs. 13–15): :class:`~magsail_mj.loads.drag.RigidDragLoad` on the facets
  of :func:`cubesat_drag_facets` — the sail as one two-sided plate of A_s at r_cp (area
  projected |ẑ_B·V̂|) plus, for ``"sail+bus"``, the six one-sided bus faces at their centroids;
  stowed: bus faces only;
* solar radiation pressure on the sail (Eqs. 16–22): :class:`~magsail_mj.loads.srp.RigidSRPLoad`
  with McInnes' optical model (aluminised Kapton, :meth:`Optics.cnusail_sail`), zero in shadow;
  none when stowed (SRP on the bus is neglected, as in the paper);
* residual dipole (Eq. 23): :class:`~magsail_mj.loads.dipole.ResidualDipoleLoad`, T = D × B.

Only torques are applied (``apply_force=False``): the world origin is the separately propagated
reference orbit, so the bus CM stays at the origin and the translational effect of drag and SRP
belongs to the lifetime analysis. Each source can be switched off.
"""

from __future__ import annotations

import math
from typing import Literal, Sequence

import mujoco
import numpy as np

from magsail_mj.environment.surfaces import FacetSet, Optics

from magsail_mj.loads.base import StepState
from magsail_mj.loads.dipole import ResidualDipoleLoad
from magsail_mj.loads.drag import RigidDragLoad
from magsail_mj.loads.srp import RigidSRPLoad
from magsail_mj.loads.tidal import GravityGradientTorqueLoad
from magsail_mj.vec3 import Vec3, cross_f, mat_t_vec_f, mat_vec_f

__all__ = ["SOURCES", "cubesat_drag_facets", "cubesat_sail_facets", "CubesatDisturbanceLoad"]

SOURCES = ("gravity_gradient", "drag", "srp", "residual_dipole")
"""Names of the disturbance sources, in the order of :meth:`CubesatDisturbanceLoad.torques_body`."""


def cubesat_sail_facets(*, area_m2: float, r_cp_m, optics: Optics | None = None) -> FacetSet:
    """The sail: one two-sided plate of ``area_m2`` with normal +z_B at r_cp (body axes)."""
    return FacetSet.plate(
        area=area_m2,
        normal=(0.0, 0.0, 1.0),
        centre=tuple(r_cp_m),
        optics=optics or Optics.cnusail_sail(),
        two_sided=True,
    )


def cubesat_drag_facets(
    *,
    configuration: Literal["stowed", "deployed"],
    surfaces: Literal["sail+bus", "sail"],
    sail_area_m2: float,
    r_cp_m,
    bus_size_m,
    bus_centroid_m,
) -> FacetSet:
    """Drag facets (Yoo et al. 2016, Eqs. 13–15): deployed ``"sail+bus"`` = sail plate + six bus faces; ``"sail"`` =
    the paper's single plate; stowed = the six bus faces whichever option."""
    bus = FacetSet.box(size=bus_size_m, centre=bus_centroid_m)
    if configuration == "stowed":
        return bus
    sail = cubesat_sail_facets(area_m2=sail_area_m2, r_cp_m=r_cp_m)
    return sail if surfaces == "sail" else FacetSet.concat([sail, bus])


class CubesatDisturbanceLoad:
    """Sum of the enabled disturbance torques on the bus (module docstring).

    Args:
      body_id: the bus body; inertia_kgm2: composite inertia (3,) or (3, 3);
      drag_facets / srp_facets: facet sets (``None`` = source off);
      drag_coefficient: C_d; residual_dipole_Am2: (3,) body-fixed D (``None`` or zero = off);
      gravity_gradient: include the gravity-gradient torque; mu: gravitational parameter.

    Per step the body → world rotation R is formed once and every source is evaluated in body
    axes with the force laws of the shared loads written out for this geometry
    (:func:`~magsail_mj.environment.gravity.gravity_gradient_torque`,
    :func:`~magsail_mj.environment.surfaces.drag_forces` as (Σ k_i c_i) × V, the sail's
    :func:`~magsail_mj.environment.surfaces.srp_forces` in scalar form, D × B), in plain Python
    floats (:mod:`magsail_mj.vec3`: a NumPy call on a 3-vector costs more than its arithmetic); the
    result equals the world-axes project loads (:attr:`reference_loads`, tested to 1e-12 relative at
    random states) at a fraction of their per-step cost. The per-source torques of the latest
    state are cached, so a probe and :meth:`add` in the same step share one evaluation.
    """

    name = "cubesat_disturbances"

    def __init__(
        self,
        body_id: int,
        *,
        inertia_kgm2,
        drag_facets: FacetSet | None,
        srp_facets: FacetSet | None,
        drag_coefficient: float = 2.2,
        residual_dipole_Am2=None,
        gravity_gradient: bool = True,
        mu: float = 3.986004418e14,
    ) -> None:
        self.body_id = int(body_id)
        I = np.asarray(inertia_kgm2, dtype=float)
        self.inertia = np.diag(I) if I.shape == (3,) else I
        self.mu = float(mu)
        self.gravity_gradient = bool(gravity_gradient)
        self.drag_facets = drag_facets
        self.srp_facets = srp_facets
        self.cd = float(drag_coefficient)
        D = None if residual_dipole_Am2 is None else np.asarray(residual_dipole_Am2, dtype=float)
        self.dipole = D if D is not None and np.any(D) else None
        self._J = tuple(self.inertia.ravel().tolist())
        self._D = tuple(D.tolist()) if self.dipole is not None else None
        self._drag = None
        if drag_facets is not None:
            # per facet: n̂_i, k_i = −½ C_d A_i c_i (centre c_i), two-sided; T = ρ (Σ_i proj_i k_i) × V
            k = (-0.5 * self.cd * drag_facets.area)[:, None] * drag_facets.centre
            self._drag = tuple(
                (*n, *ki, bool(two))
                for n, ki, two in zip(drag_facets.normal.tolist(), k.tolist(), drag_facets.two_sided.tolist())
            )
        self._sail = None
        if srp_facets is not None:
            if len(srp_facets) != 1 or not srp_facets.two_sided[0] or not np.allclose(srp_facets.normal[0], [0, 0, 1]):
                raise ValueError(
                    "srp_facets: the fast path takes one two-sided plate with normal +z "
                    f"(the sail), got {len(srp_facets)} facets"
                )
            self._sail = srp_facets
            self._sail_centre = tuple(srp_facets.centre[0].tolist())
        self._key: tuple | None = None
        self._cached: tuple[tuple[Vec3, ...], list[float]] | None = None
        self._torques: np.ndarray | None = None
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

    def _evaluate(self, state: StepState) -> tuple[tuple[Vec3, ...], list[float]]:
        """The four body-axes torques [N m] (rows of :data:`SOURCES`, zeros when off) and the
        rotation's row-major entries at ``state`` (cached for the latest state)."""
        key = (id(state), state.t)
        if key == self._key:
            return self._cached
        env, b = state.env, self.body_id
        mujoco.mju_quat2Mat(self._R, state.xquat[b])
        R = self._R.tolist()
        zero = (0.0, 0.0, 0.0)
        gg = drag = srp = dip = zero
        if self.gravity_gradient:
            gg = self._gravity_gradient((env.r_ref_eci + state.pos[b]) @ self._R.reshape(3, 3))
        if self._drag is not None and env.density_kg_m3 > 0.0:
            drag = self._drag_torque(
                mat_t_vec_f(R, _add(env.v_rel_eci.tolist(), state.vel[b].tolist())), env.density_kg_m3
            )
        if self._sail is not None and env.srp_pressure_N_m2 > 0.0:
            srp = self._sail_srp_torque(mat_t_vec_f(R, env.sun_eci.tolist()), env.srp_pressure_N_m2)
        if self._D is not None:
            dip = cross_f(self._D, mat_t_vec_f(R, env.B_eci.tolist()))
        self._key, self._cached, self._torques = key, ((gg, drag, srp, dip), R), None
        return self._cached

    def torques_body(self, state: StepState) -> np.ndarray:
        """(4, 3) body-frame torques [N m] of the sources in :data:`SOURCES` order (zeros when off)."""
        T, _ = self._evaluate(state)
        if self._torques is None:
            self._torques = np.array(T)
        return self._torques

    def _gravity_gradient(self, r_b: np.ndarray) -> Vec3:
        """T = 3μ/|r|³ û × (J û), û = r_b/|r_b| with ``r_b = Rᵀ r`` the bus position from the Earth's
        centre in body axes [m].

        ``r_b`` and ``|r_b|²`` are NumPy (BLAS) products: in the nadir attitude the torque is zero
        up to round-off (|T| ~ 1e-23 N m) and the regression summaries keep that round-off, which
        a product summed in another order (or without BLAS's fused multiply-adds) changes."""
        rn = math.sqrt(float(r_b @ r_b))
        x0, x1, x2 = r_b.tolist()
        u = (x0 / rn, x1 / rn, x2 / rn)
        k = 3.0 * self.mu / rn**3
        c = cross_f(u, mat_vec_f(self._J, u))
        return (k * c[0], k * c[1], k * c[2])

    def _drag_torque(self, V: Vec3, rho: float) -> Vec3:
        """Σ_i c_i × F_i with F_i = −½ C_d ρ A_i |n̂_i·V| V (two-sided) or max(n̂_i·V, 0) (one-sided),
        i.e. ρ (Σ_i −½ C_d A_i proj_i c_i) × V — the law of :func:`drag_forces` (body axes)."""
        V0, V1, V2 = V
        l0 = l1 = l2 = 0.0
        for n0, n1, n2, k0, k1, k2, two in self._drag:
            p = n0 * V0 + n1 * V1 + n2 * V2
            if two:
                p = abs(p)
            elif p < 0.0:
                continue  # a one-sided face turned away: no force
            l0 += p * k0
            l1 += p * k1
            l2 += p * k2
        return cross_f((rho * l0, rho * l1, rho * l2), V)

    def _sail_srp_torque(self, s: Vec3, P: float) -> Vec3:
        """r_cp × F of the sail (one two-sided plate, normal +z_B) with the law of :func:`srp_forces`:
        F = −P A cos α [(1 − r s) ŝ + (2 r s cos α + B_l r (1 − s) + (1 − r) κ) n̂_l] (scalar form)."""
        f = self._sail
        o = f.optics[0]
        c = s[2]
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
        a = scale * (1.0 - rs)
        return cross_f(self._sail_centre, (a * s[0], a * s[1], a * s[2] + scale * k_n))

    def torques_world(self, state: StepState) -> np.ndarray:
        """(4, 3) world-frame torques [N m] (rows: :data:`SOURCES`)."""
        T = self.torques_body(state)
        return T @ np.array(self._cached[1]).reshape(3, 3).T

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add R Σ T_source (world axes) to the bus torque."""
        (a, b, c, d), R = self._evaluate(state)
        w = mat_vec_f(R, (a[0] + b[0] + c[0] + d[0], a[1] + b[1] + c[1] + d[1], a[2] + b[2] + c[2] + d[2]))
        i = self.body_id
        xfrc[i, 3] += w[0]
        xfrc[i, 4] += w[1]
        xfrc[i, 5] += w[2]


def _add(a: Sequence[float], b: Sequence[float]) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])
