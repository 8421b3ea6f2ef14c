"""MjSpec builder for a spring–mass truss lattice.

One body per node, placed at its reference position, with three world-aligned slide joints
(x, y, z): a particle has no rotational state, and slide joints give 3 dofs per node where a
free joint would give 6 (measured: see README, "Design choices"). Mass is carried by each node's
tiny, non-colliding sphere geom (its rotational inertia is irrelevant: no rotational dofs). One
spatial tendon per strut between the node sites, with its own ``stiffness`` k, ``damping`` γ
and ``springlength`` l0: MuJoCo's passive tendon force ``−k (L − l0) − γ L̇`` along the tendon
is exactly the two-sided spring–dashpot law of Robb et al. 2022a. Gravity is off
and contacts are disabled; every external force enters through ``xfrc_applied``.

The model sets its MuJoCo arena (``<size memory>``) to :func:`lattice_arena_bytes`, which grows
with ``nv``: MuJoCo's default arena grows with ``nv²`` (1.65 GB at nv = 5 766) where one step of
the lattice uses 84–462 bytes per dof (Euler/implicitfast to implicit, measured with
``MjData.maxuse_arena`` at nv = 486 … 5 766; RK4 196–202).

Node ``i`` is body ``i + 1`` (body 0 is the world), and its x/y/z joints are ``qpos[3i:3i+3]``
for free nodes (clamped nodes have no joints; :func:`node_qpos_index` maps them).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from magsail_mj.mjcf.common import INTEGRATORS, set_view

from magsail_mj.lattice.geometry import Lattice

__all__ = [
    "TrussModelOptions",
    "build_truss_spec",
    "lattice_arena_bytes",
    "truss_base_spec",
    "add_particle_node",
    "add_node_sphere",
    "add_spring_tendon",
    "INTEGRATORS",
    "STRUT_RGBA",
    "NODE_RGBA",
]

STRUT_RGBA = (0.55, 0.58, 0.62, 1.0)
NODE_RGBA = (0.85, 0.85, 0.88, 1.0)
#: MuJoCo arena of a lattice model: a fixed part plus a part per degree of freedom [bytes]. The
#: per-dof part is 8.9 times the largest use measured (462 B with the implicit integrator), and the
#: fixed part covers the six dofs of a body a concept may add.
ARENA_BASE_BYTES = 1 << 20
ARENA_PER_DOF_BYTES = 4096


def lattice_arena_bytes(nv: int) -> int:
    """MuJoCo arena [bytes] set for a lattice model with ``nv`` degrees of freedom:
    ``ARENA_BASE_BYTES + ARENA_PER_DOF_BYTES · nv``."""
    if int(nv) != nv or nv < 0:
        raise ValueError(f"nv: must be an integer >= 0, got {nv!r}")
    return ARENA_BASE_BYTES + ARENA_PER_DOF_BYTES * int(nv)


@dataclass(frozen=True)
class TrussModelOptions:
    """Build options.

    Attributes:
      timestep_s: MuJoCo ``opt.timestep``.
      integrator: one of :data:`INTEGRATORS`.
      solver_tolerance: MuJoCo ``opt.tolerance`` (``None``: MuJoCo's default).
      fixed_nodes: node indices welded to the world (no joints), e.g. a clamped edge.
      node_damping_1_s: extra viscous damping per node, ``a = −c v`` (joint damping ``c m``).
      node_radius_m: radius of the visual node spheres (default: 4 % of the cube edge).
      strut_width_m: rendered tendon width (default: 1.5 % of the cube edge).
      name: model name.
    """

    timestep_s: float = 0.1
    integrator: str = "RK4"
    solver_tolerance: float | None = None
    fixed_nodes: tuple[int, ...] = ()
    node_damping_1_s: float = 0.0
    node_radius_m: float | None = None
    strut_width_m: float | None = None
    name: str = "truss"


def build_truss_spec(
    lattice: Lattice,
    *,
    masses: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray | float,
    options: TrussModelOptions = TrussModelOptions(),
) -> mujoco.MjSpec:
    """Return an ``MjSpec`` of the lattice.

    Args:
      lattice: geometry and strut table.
      masses: (n_nodes,) particle masses [kg].
      stiffness: (n_struts,) spring constants k [N/m].
      damping: strut dashpot γ [N s/m], scalar or (n_struts,).
      options: see :class:`TrussModelOptions`.
    """
    n, S = lattice.n_nodes, lattice.n_struts
    masses = np.asarray(masses, dtype=float)
    stiffness = np.asarray(stiffness, dtype=float)
    damping = np.broadcast_to(np.asarray(damping, dtype=float), (S,))
    if masses.shape != (n,) or np.any(masses <= 0):
        raise ValueError(f"masses: expected ({n},) positive values, got shape {masses.shape}")
    if stiffness.shape != (S,) or np.any(stiffness < 0):
        raise ValueError(f"stiffness: expected ({S},) values >= 0, got shape {stiffness.shape}")
    if np.any(damping < 0):
        raise ValueError("damping: must be >= 0")
    if options.integrator not in INTEGRATORS:
        raise ValueError(f"integrator: must be one of {sorted(INTEGRATORS)}, got {options.integrator!r}")

    a = lattice.cube_edge_m
    radius = options.node_radius_m or 0.04 * a
    width = options.strut_width_m or 0.015 * a
    fixed = set(int(i) for i in options.fixed_nodes)

    spec = truss_base_spec(
        name=options.name,
        timestep_s=options.timestep_s,
        integrator=options.integrator,
        solver_tolerance=options.solver_tolerance,
        extent_m=lattice.side_m,
    )
    spec.memory = lattice_arena_bytes(3 * sum(i not in fixed for i in range(n)))  # three slide joints per free node
    for i in range(n):
        free = i not in fixed
        add_particle_node(
            spec.worldbody,
            index=i,
            pos_m=lattice.nodes[i],
            mass_kg=float(masses[i]),
            free_axes=(free, free, free),
            damping_Ns_m=float(options.node_damping_1_s * masses[i]),
            radius_m=radius,
        )
    for s in range(S):
        p, q = lattice.struts[s]
        rest = float(lattice.rest_length[s])
        add_spring_tendon(
            spec,
            index=s,
            ends=(int(p), int(q)),
            stiffness_N_m=float(stiffness[s]),
            damping_Ns_m=float(damping[s]),
            springlength_m=(rest, rest),
            width_m=width,
        )
    return spec


def truss_base_spec(
    *, name: str, timestep_s: float, integrator: str, solver_tolerance: float | None, extent_m: float
) -> mujoco.MjSpec:
    """An empty truss ``MjSpec``: options (timestep, integrator, tolerance), gravity off, contacts
    disabled, numbers saved exactly, the shared view for a model of extent ``extent_m`` [m] and a
    directional sun light from +z. The caller sets ``memory`` (:func:`lattice_arena_bytes`)."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator: must be one of {sorted(INTEGRATORS)}, got {integrator!r}")
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.autolimits = True
    spec.compiler.savecompiled = False  # numbers saved exactly, explicit inertials kept
    spec.option.timestep = timestep_s
    spec.option.integrator = INTEGRATORS[integrator]
    if solver_tolerance is not None:
        spec.option.tolerance = solver_tolerance
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    set_view(spec, extent=extent_m)
    spec.visual.map.znear = 0.01
    spec.visual.map.zfar = 50.0
    spec.worldbody.add_light(
        name="sun",
        pos=[0, 0, 3 * extent_m],
        dir=[0, 0, -1],
        type=int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL),
        diffuse=[0.8, 0.8, 0.8],
    )
    return spec


def add_particle_node(
    parent: mujoco.MjsBody,
    *,
    index: int,
    pos_m: np.ndarray,
    mass_kg: float,
    free_axes: tuple[bool, bool, bool],
    damping_Ns_m: float,
    radius_m: float,
) -> mujoco.MjsBody:
    """Node ``index`` as a particle: body ``n<index>`` at ``pos_m`` (parent frame, world-aligned)
    with a slide joint ``n<index>_x|y|z`` along each world axis in ``free_axes`` (joint damping
    ``damping_Ns_m``), its mass on a non-colliding sphere geom of radius ``radius_m`` and its
    site ``s<index>`` at the body origin (where tendons attach)."""
    body = parent.add_body(name=f"n{index}", pos=[float(x) for x in pos_m])
    for ax, axis, free in zip("xyz", np.eye(3), free_axes):
        if free:
            body.add_joint(
                name=f"n{index}_{ax}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis.tolist(), damping=damping_Ns_m
            )
    add_node_sphere(body, mass_kg=mass_kg, radius_m=radius_m)
    body.add_site(name=f"s{index}", size=[radius_m * 0.5, 0, 0], group=5)
    return body


def add_node_sphere(body: mujoco.MjsBody, *, mass_kg: float, radius_m: float, pos_m=(0.0, 0.0, 0.0)) -> None:
    """A node's non-colliding sphere geom of mass ``mass_kg`` (group 1) at ``pos_m`` (body frame)."""
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[radius_m, 0, 0],
        pos=[float(x) for x in pos_m],
        contype=0,
        conaffinity=0,
        mass=mass_kg,
        rgba=list(NODE_RGBA),
        group=1,
    )


def add_spring_tendon(
    spec: mujoco.MjSpec,
    *,
    index: int,
    ends: tuple[int, int],
    stiffness_N_m: float,
    damping_Ns_m: float,
    springlength_m: tuple[float, float],
    width_m: float,
) -> mujoco.MjsTendon:
    """Tendon ``t<index>`` from site ``s<ends[0]>`` to ``s<ends[1]>``: passive force
    ``−k (L − l_hi) − γ L̇`` above ``l_hi``, ``−k (L − l_lo) − γ L̇`` below ``l_lo`` and ``−γ L̇`` in
    between (``springlength_m = (l_lo, l_hi)``, MuJoCo's dead band)."""
    tendon = spec.add_tendon(
        name=f"t{index}", stiffness=stiffness_N_m, damping=damping_Ns_m, width=width_m, rgba=list(STRUT_RGBA)
    )
    tendon.springlength = [float(springlength_m[0]), float(springlength_m[1])]
    tendon.wrap_site(f"s{ends[0]}")
    tendon.wrap_site(f"s{ends[1]}")
    return tendon


def node_positions_from_qpos(model: mujoco.MjModel, qpos: np.ndarray, *, n_nodes: int) -> np.ndarray:
    """World node positions ``(…, n_nodes, 3)`` from ``qpos`` (``(…, nq)``) of a truss model.

    Node ``i`` is body ``i + 1`` at reference ``body_pos``; a free node adds its three slide
    coordinates, a clamped node (no joints) stays at its reference.
    """
    qpos = np.asarray(qpos)
    bodies = np.arange(1, n_nodes + 1)
    ref = model.body_pos[bodies]
    out = np.broadcast_to(ref, qpos.shape[:-1] + ref.shape).copy()
    has = model.body_jntnum[bodies] == 3
    adr = model.jnt_qposadr[model.body_jntadr[bodies[has]]]
    out[..., has, :] += qpos[..., adr[:, None] + np.arange(3)]
    return out
