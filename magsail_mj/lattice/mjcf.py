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

__all__ = ["TrussModelOptions", "build_truss_spec", "lattice_arena_bytes", "INTEGRATORS", "STRUT_RGBA", "NODE_RGBA"]

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

    spec = mujoco.MjSpec()
    spec.modelname = options.name
    spec.compiler.autolimits = True
    spec.compiler.savecompiled = False  # numbers saved exactly, explicit inertials kept
    spec.option.timestep = options.timestep_s
    spec.option.integrator = INTEGRATORS[options.integrator]
    if options.solver_tolerance is not None:
        spec.option.tolerance = options.solver_tolerance
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    spec.memory = lattice_arena_bytes(3 * sum(i not in fixed for i in range(n)))  # three slide joints per free node
    set_view(spec, extent=lattice.side_m)
    spec.visual.map.znear = 0.01
    spec.visual.map.zfar = 50.0

    spec.worldbody.add_light(
        name="sun",
        pos=[0, 0, 3 * lattice.side_m],
        dir=[0, 0, -1],
        type=int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL),
        diffuse=[0.8, 0.8, 0.8],
    )
    axes = np.eye(3)
    for i in range(n):
        body = spec.worldbody.add_body(name=f"n{i}", pos=lattice.nodes[i].tolist())
        if i not in fixed:
            for ax, axis in zip("xyz", axes):
                body.add_joint(
                    name=f"n{i}_{ax}",
                    type=mujoco.mjtJoint.mjJNT_SLIDE,
                    axis=axis.tolist(),
                    damping=float(options.node_damping_1_s * masses[i]),
                )
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[radius, 0, 0],
            contype=0,
            conaffinity=0,
            mass=float(masses[i]),
            rgba=list(NODE_RGBA),
            group=1,
        )
        body.add_site(name=f"s{i}", size=[radius * 0.5, 0, 0], group=5)
    for s in range(S):
        p, q = lattice.struts[s]
        tendon = spec.add_tendon(
            name=f"t{s}", stiffness=float(stiffness[s]), damping=float(damping[s]), width=width, rgba=list(STRUT_RGBA)
        )
        tendon.springlength = [float(lattice.rest_length[s]), float(lattice.rest_length[s])]
        tendon.wrap_site(f"s{p}")
        tendon.wrap_site(f"s{q}")
    return spec


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
