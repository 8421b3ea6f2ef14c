r"""Loads of the ``structure`` concept, vectorised over nodes and members with index arrays built
once (the one door: each adds into ``xfrc_applied``, :mod:`magsail_mj.loads.base`).

:class:`NodeTidalLoad`
    The exact tidal force on every mass point of the structure (each node's lumped mass at the
    node, each rigid part's own mass at its centre), ``F_k = m_k [g(r_ref + x_k) − g(r_ref)]``
    (:func:`magsail_mj.environment.gravity.tidal_acceleration`, two-body plus J2 when the
    reference orbit has it), applied at the point (a node held by a rigid part gives its part a
    torque too), and the gravity-gradient torque of each rigid part's own inertia,
    ``3μ/|r|⁵ r × (I_w r)`` with ``r = r_ref + x_part`` and ``I_w = R I Rᵀ``. Not modelled: the
    gradient torque on a beam node's small rotational inertia.

:class:`RodDipoleLoad`
    One magnetorquer rod along each member of a member set: rod ``r`` on member ``a → b`` has the
    dipole ``m_r = u_r m_max,r r̂`` along the member's current axis ``r̂ = (x_b − x_a)/|x_b − x_a|``,
    ``u_r ∈ [−1, 1]`` the held command's activation (``state.ctrl.activation``; no command: off).
    In the uniform field ``B`` (world axes, the field at the reference point) its couple
    ``m_r × B`` is applied as the force pair perpendicular to the member,
    ``F_b = −F_a = (m_r × B) × r_ab / |r_ab|²``
    (:func:`magsail_mj.loads.magnetorquer_rods.rod_pair_forces`): zero net force and the moment
    ``m_r × B`` about any point, for any deformation.

:class:`LoopLorentzLoad`
    Current loops along member sets (:mod:`magsail_mj.concepts.structure.circuits`): loop ``L``
    carries the current ``I_L`` (``state.ctrl.currents_A``; no command: off) along its directed
    members ``a → b``; in the uniform field ``B`` each member feels the Lorentz force
    ``f = I_L (x_b − x_a) × B`` (straight wire), half at each end node, on the current positions
    (Robb et al. 2022b, Eq. 16). Over a closed loop the forces sum to zero and their moment about
    any point is ``m_L × B`` with ``m_L = I_L a_L``, ``a_L = ½ Σ x_a × x_b``, for any deformation.

:class:`PanelSurfaceLoad`
    Solar radiation pressure and free-molecular drag on every panel, each quad as the two
    triangles the structure splits it into (:meth:`~magsail_mj.structure.model.Panels.triangles`,
    along its 0–2 diagonal). Triangle ``(a, b, c)`` at the **current** node positions has the
    vector area ``½ (x_b − x_a) × (x_c − x_a)`` (area ``A``, unit front normal ``n̂``); its force
    goes in equal thirds to its three nodes. Both faces take light and flow (a membrane).
    SRP (:func:`magsail_mj.loads.srp.plate_srp_forces`, the flat-plate law of
    :mod:`magsail_mj.environment.surfaces`): with the panel's specular, diffuse and absorbed
    fractions ``ρ_s, ρ_d, ρ_a`` (read as ``r = ρ_s + ρ_d``, ``s = ρ_s / r`` with Lambertian
    diffusion, ``B = 2/3`` on both faces and equal emissivities: no thermal re-emission),
    ``F = −P A cos α [(1 − ρ_s) ŝ + (2 ρ_s cos α + ⅔ ρ_d) n̂_l]``, ``cos α = |ŝ·n̂|``, ``n̂_l`` the
    lit face's normal; ``P = state.env.srp_pressure_N_m2`` (zero in the Earth's shadow), ``ŝ =
    state.env.sun_eci``. Drag (:func:`magsail_mj.loads.drag.plate_drag_forces`):
    ``F = −½ C_D ρ A |n̂·V| V`` with the panel's ``drag_coefficient``, ``ρ =
    state.env.density_kg_m3`` and ``V = state.env.v_rel_eci``, the reference point's velocity
    relative to the atmosphere, the same for every panel (the nodes' own velocities about the
    reference point, ``ω r`` ~ 0.1 m/s over 50 m at 2e-3 rad/s against ~7.5 km/s, are left out).
    Self-shadowing and the flow's shadowing by other panels are not modelled. The net force
    moves the structure off the reference orbit (the world origin), as on the lattices.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from magsail_mj.concepts.structure.circuits import LoopEdges
from magsail_mj.concepts.structure.model import MassPoints, NodeFrames, cross_rows, quat_matrices
from magsail_mj.environment.gravity import tidal_acceleration
from magsail_mj.environment.surfaces import Optics, uniform_srp_constants
from magsail_mj.loads.base import StepState
from magsail_mj.loads.drag import plate_drag_forces
from magsail_mj.loads.magnetorquer_rods import rod_pair_forces
from magsail_mj.loads.srp import plate_srp_forces
from magsail_mj.structure.model import Panels
from magsail_mj.vec3 import cross3

__all__ = ["NodeTidalLoad", "RodDipoleLoad", "LoopLorentzLoad", "PanelSurfaceLoad", "panel_srp_constants"]


class NodeTidalLoad:
    """Tidal gravity on every mass point of the structure (module docstring).

    Args:
      points: the structure's mass points (:class:`~magsail_mj.concepts.structure.model.MassPoints`).
      mu, j2, J2, R_j2: the environment's gravity (``Environment.gravity_params``).
    """

    name = "tidal_gravity"

    def __init__(self, points: MassPoints, *, mu: float, j2: bool, J2: float, R_j2: float) -> None:
        self.points = points
        self.mass_col = np.asarray(points.mass_kg, dtype=float)[:, None]
        self.mu, self.j2, self.J2, self.R_j2 = float(mu), bool(j2), float(J2), float(R_j2)

    def forces(self, r_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
        """(k, 3) tidal forces [N] on the points at world positions ``x`` [m]."""
        a = tidal_acceleration(r_ref, x, mu=self.mu, j2=self.j2, J2=self.J2, R=self.R_j2)
        return self.mass_col * a

    def part_torques(self, r_ref: np.ndarray, x: np.ndarray, xquat: np.ndarray) -> np.ndarray:
        """(P, 3) gravity-gradient torques of the parts' own inertia [N m], world axes."""
        p = self.points
        k = p.part_point
        r = np.asarray(r_ref, dtype=float) + x[k]
        R = quat_matrices(xquat[p.frames.body[k]])
        r_body = np.einsum("kji,kj->ki", R, r)  # Rᵀ r: I_w r = R I Rᵀ r
        r2 = np.einsum("ki,ki->k", r, r)
        scale = 3.0 * self.mu / (r2 * r2 * np.sqrt(r2))
        torque_body = cross_rows(r_body, np.einsum("kij,kj->ki", p.part_inertia_kg_m2, r_body))
        return scale[:, None] * np.einsum("kij,kj->ki", R, torque_body)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the tidal forces (and the parts' gradient torques) into ``xfrc`` (world frame)."""
        r_ref = np.asarray(state.env.r_ref_eci, dtype=float)
        frames = self.points.frames
        x = frames.positions(state.pos, state.xquat)
        frames.apply(self.forces(r_ref, x), state.xquat, xfrc)
        k = self.points.part_point
        if k.size and np.any(self.points.part_inertia_kg_m2):
            np.add.at(xfrc[:, 3:], frames.body[k], self.part_torques(r_ref, x, state.xquat))


class RodDipoleLoad:
    """Magnetorquer rods along members (module docstring).

    Args:
      nodes: the nodes' frames (:class:`~magsail_mj.concepts.structure.model.NodeFrames`).
      ends: (R, 2) end nodes ``(a, b)`` of each rod's member.
      dipole_max_Am2: (R,) each rod's largest dipole [A m²].
      B_fixed_T: a fixed uniform field [T] (tests); default ``None`` reads ``state.env.B_eci``.
    """

    name = "magnetorquer_rods"

    def __init__(
        self, nodes: NodeFrames, ends: np.ndarray, dipole_max_Am2: np.ndarray, *, B_fixed_T: np.ndarray | None = None
    ) -> None:
        self.nodes = nodes
        self.ends = np.asarray(ends, dtype=np.int64).reshape(-1, 2)
        self.dipole_max_Am2 = np.asarray(dipole_max_Am2, dtype=float)
        if self.dipole_max_Am2.shape != (self.ends.shape[0],):
            raise ValueError(
                f"dipole_max_Am2: one dipole per rod ({self.ends.shape[0]}) needed, "
                f"got shape {self.dipole_max_Am2.shape}"
            )
        self.B_fixed_T = None if B_fixed_T is None else np.asarray(B_fixed_T, dtype=float)
        used = np.unique(self.ends)
        self.used = used  # the nodes the rods use, ascending; the rods index them locally
        local = np.searchsorted(used, self.ends)
        self._a, self._b = local[:, 0], local[:, 1]
        n = self.ends.shape[0]
        rows = np.concatenate([self._b, self._a])
        vals = np.concatenate([np.ones(n), -np.ones(n)])
        self._pair = sparse.csr_matrix((vals, (rows, np.tile(np.arange(n), 2))), shape=(used.size, n))
        self.used_frames = nodes.subset(used)

    @property
    def n_rods(self) -> int:
        return int(self.ends.shape[0])

    def field(self, state: StepState) -> np.ndarray:
        """The uniform field [T], world axes: the fixed one or ``state.env.B_eci``."""
        if self.B_fixed_T is not None:
            return self.B_fixed_T
        return np.asarray(state.env.B_eci, dtype=float)

    @staticmethod
    def activation(state: StepState) -> np.ndarray | None:
        """The held command's activations ``u`` (``None``: no command yet, every rod off)."""
        ctrl = state.ctrl
        return None if ctrl is None else ctrl.activation

    def dipoles_world(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(R, 3) rod dipoles ``u m_max r̂`` [A m²] with the rods' end nodes at ``x`` (used nodes)."""
        r = x[self._b] - x[self._a]
        scale = u * self.dipole_max_Am2 / np.sqrt(np.einsum("ij,ij->i", r, r))
        return scale[:, None] * r

    def torque_world(self, state: StepState) -> np.ndarray:
        """``Σ m_r × B`` [N m], world axes: the rods' torque about any point."""
        u = self.activation(state)
        if u is None:
            return np.zeros(3)
        x = self.node_positions(state)
        return cross3(self.dipoles_world(x, u).sum(axis=0), self.field(state))

    def node_positions(self, state: StepState) -> np.ndarray:
        """(k, 3) world positions of the nodes the rods use (``used``, in order) [m]."""
        return self.used_frames.positions(state.pos, state.xquat)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add every rod's force pair into ``xfrc`` (vectorised over the rods)."""
        u = self.activation(state)
        if u is None or not np.any(u):
            return
        x = self.node_positions(state)
        F = rod_pair_forces(x[self._a], x[self._b], u * self.dipole_max_Am2, self.field(state))
        self.used_frames.apply(self._pair @ F, state.xquat, xfrc)


class LoopLorentzLoad:
    """Lorentz forces on current loops along members (module docstring).

    Args:
      nodes: the nodes' frames (:class:`~magsail_mj.concepts.structure.model.NodeFrames`).
      loops: the loops' directed edges (:class:`~magsail_mj.concepts.structure.circuits.LoopEdges`).
      B_fixed_T: a fixed uniform field [T] (tests); default ``None`` reads ``state.env.B_eci``.

    Built once: the nodes the loops use (``used``, ascending; the edges index them locally), the
    (nodes × edges) incidence with 1 at both ends of every edge (each end takes half, ``g_e = ½ I
    (x_b − x_a)``, so ``F_i = (Σ_e∋i g_e) × B``) and the (loops × edges) sum of the vector areas.
    """

    name = "current_loops"

    def __init__(self, nodes: NodeFrames, loops: LoopEdges, *, B_fixed_T: np.ndarray | None = None) -> None:
        self.loops = loops
        self.B_fixed_T = None if B_fixed_T is None else np.asarray(B_fixed_T, dtype=float)
        self.used = np.unique(np.concatenate([loops.src, loops.dst]))
        self._a = np.searchsorted(self.used, loops.src)
        self._b = np.searchsorted(self.used, loops.dst)
        self._loop = np.asarray(loops.loop, dtype=np.int64)
        s = self._loop.size
        edge = np.arange(s)
        self._ends = sparse.csr_matrix(
            (np.ones(2 * s), (np.concatenate([self._a, self._b]), np.tile(edge, 2))), shape=(self.used.size, s)
        )
        self._sum = sparse.csr_matrix((np.full(s, 0.5), (self._loop, edge)), shape=(loops.n_loops, s))
        self.used_frames = nodes.subset(self.used)

    @property
    def n_loops(self) -> int:
        return self.loops.n_loops

    def field(self, state: StepState) -> np.ndarray:
        """The uniform field [T], world axes: the fixed one or ``state.env.B_eci``."""
        if self.B_fixed_T is not None:
            return self.B_fixed_T
        return np.asarray(state.env.B_eci, dtype=float)

    @staticmethod
    def currents(state: StepState) -> np.ndarray | None:
        """The held command's loop currents [A] (``None``: no command yet, every loop off)."""
        ctrl = state.ctrl
        return None if ctrl is None else ctrl.currents_A

    def node_positions(self, state: StepState) -> np.ndarray:
        """(k, 3) world positions of the nodes the loops use (``used``, in order) [m]."""
        return self.used_frames.positions(state.pos, state.xquat)

    def vector_areas(self, x: np.ndarray) -> np.ndarray:
        """(L, 3) the loops' vector areas ``½ Σ x_a × x_b`` [m²] with the used nodes at ``x``."""
        return self._sum @ cross_rows(x[self._a], x[self._b])

    def node_forces(self, x: np.ndarray, currents_A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """(k, 3) forces [N] on the used nodes at ``x`` for the loop currents ``currents_A`` (L,)
        in the field ``B`` (3,)."""
        g = (0.5 * np.asarray(currents_A, dtype=float)[self._loop])[:, None] * (x[self._b] - x[self._a])
        return cross_rows(self._ends @ g, np.asarray(B, dtype=float)[None, :])

    def torque_world(self, state: StepState) -> np.ndarray:
        """``Σ I_L a_L × B`` [N m], world axes: the loops' torque about any point."""
        current = self.currents(state)
        if current is None or not current.size:
            return np.zeros(3)
        m = current @ self.vector_areas(self.node_positions(state))
        return cross3(m, self.field(state))

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add every loop member's Lorentz force, half at each end, into ``xfrc``."""
        current = self.currents(state)
        if current is None or not np.any(current):
            return
        x = self.node_positions(state)
        self.used_frames.apply(self.node_forces(x, current, self.field(state)), state.xquat, xfrc)


def panel_srp_constants(reflectivity: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(r s, K_front, K_back, 1 − r s)`` of :func:`~magsail_mj.loads.srp.plate_srp_forces`, (k,)
    each, for panels of reflectivity rows ``(ρ_s, ρ_d, ρ_a)`` (k, 3): the
    :class:`~magsail_mj.environment.surfaces.Optics` ``r = ρ_s + ρ_d``, ``s = ρ_s / r`` (0 for a
    black panel) with its Lambertian defaults, folded by
    :func:`~magsail_mj.environment.surfaces.uniform_srp_constants` (once per distinct row)."""
    rows = np.asarray(reflectivity, dtype=float).reshape(-1, 3)
    unique, inverse = np.unique(rows, axis=0, return_inverse=True)
    constants = np.empty((unique.shape[0], 4))
    for i, (specular, diffuse, _) in enumerate(unique.tolist()):
        r = min(max(specular + diffuse, 0.0), 1.0)
        s = min(specular / r, 1.0) if r > 0 else 0.0
        constants[i] = uniform_srp_constants(Optics(r=r, s=s))
    rs, k_front, k_back, one_minus_rs = constants[np.ravel(inverse)].T
    return rs.copy(), k_front.copy(), k_back.copy(), one_minus_rs.copy()


class PanelSurfaceLoad:
    """Solar radiation pressure and drag on the structure's panels (module docstring).

    Args:
      nodes: the nodes' frames (:class:`~magsail_mj.concepts.structure.model.NodeFrames`).
      panels: the structure's panel table (at least one panel).
      srp: apply solar radiation pressure; drag: apply drag.

    Index arrays (each triangle's corners among the nodes the panels use, the (nodes × triangles)
    sharing matrix of thirds, the per-triangle optical constants and drag coefficients) are built
    once; a step is a gather, one cross product, the two force laws and one sparse product, in the
    (3, k) component-major layout of the lattice loads.
    """

    name = "panel_srp_drag"

    def __init__(self, nodes: NodeFrames, panels: Panels, *, srp: bool, drag: bool) -> None:
        if len(panels) == 0:
            raise ValueError("panels: the structure has no panels to take solar pressure or drag")
        self.srp, self.drag = bool(srp), bool(drag)
        tri = panels.triangles()
        quad = np.flatnonzero(panels.nodes[:, 3] >= 0)
        self.panel_of_triangle = np.concatenate([np.arange(len(panels)), quad]).astype(np.int64)
        self.used = np.unique(tri)
        local = np.searchsorted(self.used, tri)
        self._corner = np.ascontiguousarray(local.T)  # (3, t): corner a, b, c of every triangle
        t = tri.shape[0]
        self._share = sparse.csr_matrix(
            (np.full(3 * t, 1.0 / 3.0), (local.ravel(), np.repeat(np.arange(t), 3))), shape=(self.used.size, t)
        )
        self.frames = nodes.subset(self.used)
        self.rs, self.k_front, self.k_back, self.one_minus_rs = panel_srp_constants(
            panels.reflectivity[self.panel_of_triangle]
        )
        self.cd = np.asarray(panels.drag_coefficient, dtype=float)[self.panel_of_triangle]

    @property
    def n_triangles(self) -> int:
        return int(self._corner.shape[1])

    def area_normal(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Areas (t,) [m²] and unit front normals (3, t) of the triangles with the used nodes at
        ``x`` (u, 3) [m] (a triangle collapsed to a line has area 0 and normal 0)."""
        X = x.T
        p0 = X[:, self._corner[0]]
        d1 = X[:, self._corner[1]] - p0
        d2 = X[:, self._corner[2]] - p0
        A = np.empty_like(d1)
        A[0] = d1[1] * d2[2] - d1[2] * d2[1]
        A[1] = d1[2] * d2[0] - d1[0] * d2[2]
        A[2] = d1[0] * d2[1] - d1[1] * d2[0]
        area2 = np.sqrt(A[0] * A[0] + A[1] * A[1] + A[2] * A[2])  # 2 × area
        n = np.divide(A, area2, out=np.zeros_like(A), where=area2 > 0.0)
        return 0.5 * area2, n

    def triangle_forces(self, env, x: np.ndarray, *, srp: bool = True, drag: bool = True) -> np.ndarray:
        """(3, t) force on every triangle [N], world axes: the SRP and drag of those of the two that
        are on (this load's flags and the arguments) at the environment sample ``env``."""
        F = np.zeros((3, self.n_triangles))
        P = float(env.srp_pressure_N_m2) if (self.srp and srp) else 0.0
        rho = float(env.density_kg_m3) if (self.drag and drag) else 0.0
        if P == 0.0 and rho == 0.0:
            return F
        area, n = self.area_normal(x)
        if P != 0.0:
            F += plate_srp_forces(
                area,
                n,
                np.asarray(env.sun_eci, dtype=float),
                P,
                rs=self.rs,
                k_front=self.k_front,
                k_back=self.k_back,
                one_minus_rs=self.one_minus_rs,
            )
        if rho != 0.0:
            F += plate_drag_forces(area, n, np.asarray(env.v_rel_eci, dtype=float)[:, None], rho, self.cd)
        return F

    def node_positions(self, state: StepState) -> np.ndarray:
        """(u, 3) world positions of the nodes the panels use (``used``, in order) [m]."""
        return self.frames.positions(state.pos, state.xquat)

    def node_forces(self, state: StepState, *, srp: bool = True, drag: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """``(x, F)``: the used nodes' positions (u, 3) [m] and the forces on them (u, 3) [N]."""
        x = self.node_positions(state)
        return x, self._share @ self.triangle_forces(state.env, x, srp=srp, drag=drag).T

    def wrench(self, state: StepState, center_m: np.ndarray, *, srp: bool = True, drag: bool = True) -> np.ndarray:
        """(6,) net force [N] and its moment about ``center_m`` [N m], world axes."""
        x, F = self.node_forces(state, srp=srp, drag=drag)
        force = F.sum(axis=0)
        return np.concatenate([force, cross_rows(x, F).sum(axis=0) - cross3(np.asarray(center_m, float), force)])

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the panels' forces at their nodes into ``xfrc`` (world frame)."""
        env = state.env
        if not ((self.srp and env.srp_pressure_N_m2 != 0.0) or (self.drag and env.density_kg_m3 != 0.0)):
            return
        _, F = self.node_forces(state)
        self.frames.apply(F, state.xquat, xfrc)
