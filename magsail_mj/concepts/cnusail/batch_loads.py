r"""The CNUSAIL cubesat's loads over a world axis: disturbance torques and the magnetorquer torque.

For N worlds at once, with each world's own parameters, the torques of
:class:`~magsail_mj.concepts.cnusail.disturbances.CubesatDisturbanceLoad` (Yoo et al. 2016,
Eqs. 12–23) and :class:`~magsail_mj.loads.actuators_cubesat.MagnetorquerLoad` (Eq. 5), evaluated
in body axes of the bus and added to its row of ``xfrc_applied`` in world axes:

* gravity gradient ``T = 3μ/|r|³ û × (J û)``, ``r_b = Rᵀ (r_ref + p)`` (a BLAS product per world,
  as the single run forms it), ``û = r_b/|r_b|``;
* drag ``T = ρ (Σ_i −½ C_d A_i proj_i c_i) × V`` over the drag facets (``proj_i = |n̂_i·V|`` for a
  two-sided facet, ``max(n̂_i·V, 0)`` for a one-sided one), ``V = Rᵀ (v_rel + v)``;
* SRP on the sail (deployed: one two-sided plate, normal +z_B), McInnes' optical model in the
  scalar form of the single run, zero in shadow;
* residual dipole ``T = D × Rᵀ B``;
* magnetorquers ``T_w = (R m) × B`` with the held effective dipole m (zero while blanked).

The facet loop runs over the facets (7 at most), not over the worlds; every world's facets are in
``(N, F)`` arrays. Each quantity is computed in the single run's order of operations
(:mod:`magsail_mj.batch.worldmath`), so a world's torques equal its single run's bit for bit.
Parameters are read from each world's own load objects (the very numbers its single run uses).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from magsail_mj.batch.environment import EnvSamples
from magsail_mj.batch.worldmath import (
    cross,
    dot_blas,
    mat_t_vec,
    mat_vec,
    normalise_quat,
    pow_per_world,
    quat_to_mat,
    vec_mat_blas,
)
from magsail_mj.concepts.cnusail.disturbances import CubesatDisturbanceLoad

__all__ = ["DisturbanceWorlds", "BodyState", "magnetorquer_torque"]


class BodyState:
    """The bus of every world at one instant: its ``qpos`` quaternion ``quat`` (N, 4), position
    ``pos`` (N, 3) [m] and velocity ``vel`` (N, 3) [m/s] (world axes), the environment ``env`` then,
    and, formed on first use, ``R`` (N, 9): the body → world rotation (row-major) of the quaternion
    divided by its norm (as :class:`~magsail_mj.sim.BodyKinematics` forms the body's pose)."""

    def __init__(self, quat: np.ndarray, pos: np.ndarray, vel: np.ndarray, env: EnvSamples) -> None:
        self.quat, self.pos, self.vel, self.env = quat, pos, vel, env

    @cached_property
    def R(self) -> np.ndarray:
        return quat_to_mat(normalise_quat(self.quat))


class DisturbanceWorlds:
    """The disturbance torques of N worlds (module docstring), from each world's
    :class:`CubesatDisturbanceLoad`.

    Raises:
      ValueError: the worlds' loads act on different bodies, or their drag facet sets differ in
        count (``spacecraft.drag_surfaces`` or ``spacecraft.configuration``).
    """

    def __init__(self, loads: list[CubesatDisturbanceLoad]) -> None:
        n = len(loads)
        bodies = {ld.body_id for ld in loads}
        if len(bodies) != 1:
            raise ValueError(f"loads: the worlds' disturbances act on different bodies {sorted(bodies)}")
        self.body_id = bodies.pop()
        self.gg = np.array([ld.gravity_gradient for ld in loads])
        self.mu3 = np.array([3.0 * ld.mu for ld in loads])
        self.J = np.array([ld._J for ld in loads], dtype=float)  # (N, 9) row-major composite inertia
        self.has_dipole = np.array([ld._D is not None for ld in loads])
        self.D = np.array([ld._D if ld._D is not None else (0.0, 0.0, 0.0) for ld in loads], dtype=float)
        counts = {len(ld._drag) for ld in loads if ld._drag is not None}
        if len(counts) > 1:
            raise ValueError(f"loads: the worlds' drag facet counts differ {sorted(counts)}")
        self.has_drag = np.array([ld._drag is not None for ld in loads])
        n_facets = counts.pop() if counts else 0
        facets = np.zeros((n, n_facets, 7))
        for k, ld in enumerate(loads):
            if ld._drag is not None:
                facets[k] = np.array(ld._drag, dtype=float)
        # per world and facet: normal n̂ (N, F, 3), k = −½ C_d A c (N, F, 3), two-sided (N, F)
        self.facet_n = np.ascontiguousarray(facets[:, :, 0:3])
        self.facet_k = np.ascontiguousarray(facets[:, :, 3:6])
        self.facet_two = facets[:, :, 6] > 0.5
        self.all_drag = bool(self.has_drag.all())
        self.all_gg = bool(self.gg.all())
        self.has_sail = np.array([ld._sail is not None for ld in loads])
        sails = [ld for ld in loads if ld._sail is not None]
        self.any_sail = bool(sails)
        if self.any_sail:
            ref = sails[0]

            def sail_value(fn):
                return np.array([fn(ld) if ld._sail is not None else fn(ref) for ld in loads], dtype=float)

            self.sail_centre = sail_value(lambda ld: ld._sail_centre)
            self.sail_area = sail_value(lambda ld: float(ld._sail.area[0]))
            opt = [(ld if ld._sail is not None else ref)._sail.optics[0] for ld in loads]
            self.opt_r = np.array([o.r for o in opt], dtype=float)
            self.opt_s = np.array([o.s for o in opt], dtype=float)
            self.B_f = np.array([o.B_f for o in opt], dtype=float)
            self.B_b = np.array([o.B_b for o in opt], dtype=float)
            self.e_f = np.array([o.e_f for o in opt], dtype=float)
            self.e_b = np.array([o.e_b for o in opt], dtype=float)
            self.swap_back = np.array([bool(o.swap_back) for o in opt])

    def torques_body(self, s: BodyState) -> np.ndarray:
        """(N, 4, 3) body-axes torques [N m] of the sources gravity gradient, drag, SRP, residual
        dipole (zeros where a source is off), as :meth:`CubesatDisturbanceLoad.torques_body`."""
        n = len(s.R)
        zero = np.zeros((n, 3))
        out = np.empty((n, 4, 3))
        out[:, 0] = self._gravity_gradient(s) if self.gg.any() else zero
        out[:, 1] = self._drag(s) if self.has_drag.any() else zero
        out[:, 2] = self._srp(s) if self.any_sail else zero
        if self.has_dipole.any():
            out[:, 3] = np.where(self.has_dipole[:, None], cross(self.D, mat_t_vec(s.R, s.env.B_eci)), 0.0)
        else:
            out[:, 3] = zero
        return out

    def torque_world(self, T: np.ndarray, R: np.ndarray) -> np.ndarray:
        """(N, 3) world-axes total of body torques ``T`` (N, 4, 3): ``R (T₀ + T₁ + T₂ + T₃)``, summed
        left to right as :meth:`CubesatDisturbanceLoad.add`."""
        return mat_vec(R, ((T[:, 0] + T[:, 1]) + T[:, 2]) + T[:, 3])

    def _gravity_gradient(self, s: BodyState) -> np.ndarray:
        r_b = vec_mat_blas(s.env.r_ref_eci + s.pos, s.R)
        rn = np.sqrt(dot_blas(r_b, r_b))
        u = r_b / rn[:, None]
        k = self.mu3 / pow_per_world(rn, 3)
        T = k[:, None] * cross(u, mat_vec(self.J, u))
        return T if self.all_gg else np.where(self.gg[:, None], T, 0.0)

    def _drag(self, s: BodyState) -> np.ndarray:
        """The facets' sum ``l = Σ_i proj_i k_i`` is accumulated facet by facet in the single run's
        order; a facet turned away adds ±0.0, which leaves the sum as it is (it starts at +0.0, so
        it is never −0.0)."""
        rho = s.env.density_kg_m3
        V = mat_t_vec(s.R, s.env.v_rel_eci + s.vel)
        n, two = self.facet_n, self.facet_two
        p = n[:, :, 0] * V[:, 0:1] + n[:, :, 1] * V[:, 1:2] + n[:, :, 2] * V[:, 2:3]  # (N, F)
        p = np.where(two, np.abs(p), np.where(p < 0.0, 0.0, p))  # a one-sided face turned away: nothing
        contrib = p[:, :, None] * self.facet_k  # (N, F, 3)
        lever = np.zeros(V.shape)
        for f in range(contrib.shape[1]):
            lever += contrib[:, f]
        T = cross(rho[:, None] * lever, V)
        on = rho > 0.0 if self.all_drag else self.has_drag & (rho > 0.0)
        return T if on.all() else np.where(on[:, None], T, 0.0)

    def _srp(self, s: BodyState) -> np.ndarray:
        P = s.env.srp_pressure_N_m2
        sv = mat_t_vec(s.R, s.env.sun_eci)
        c = sv[:, 2]
        front = c >= 0.0
        cos_a = np.abs(c)
        keep = front | ~self.swap_back
        B_l = np.where(keep, self.B_f, self.B_b)
        B_d = np.where(keep, self.B_b, self.B_f)
        e_l = np.where(keep, self.e_f, self.e_b)
        e_d = np.where(keep, self.e_b, self.e_f)
        esum = e_l + e_d
        with np.errstate(divide="ignore", invalid="ignore"):
            kappa = np.where(esum > 0, (e_l * B_l - e_d * B_d) / esum, 0.0)
        r, so = self.opt_r, self.opt_s
        rs = r * so
        k_n = (2.0 * rs * cos_a + B_l * r * (1.0 - so) + (1.0 - r) * kappa) * np.where(front, 1.0, -1.0)
        scale = -P * self.sail_area * cos_a
        a = scale * (1.0 - rs)
        F = np.stack((a * sv[:, 0], a * sv[:, 1], a * sv[:, 2] + scale * k_n), axis=1)
        return np.where((self.has_sail & (P > 0.0))[:, None], cross(self.sail_centre, F), 0.0)


def magnetorquer_torque(dipole_body: np.ndarray, s: BodyState) -> tuple[np.ndarray, np.ndarray]:
    """``((R m) × B, acts)``: the (N, 3) world-axes magnetorquer torque [N m] of the body-axes dipoles
    ``dipole_body`` [A m²] and where it is added (N,) — as :class:`MagnetorquerLoad`, which adds
    nothing for a zero dipole or a zero torque."""
    m = dipole_body
    on = (m[:, 0] != 0.0) | (m[:, 1] != 0.0) | (m[:, 2] != 0.0)
    T = cross(mat_vec(s.R, m), s.env.B_eci)
    acts = on & ((T[:, 0] != 0.0) | (T[:, 1] != 0.0) | (T[:, 2] != 0.0))
    return T, acts
