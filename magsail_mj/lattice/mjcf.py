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

Large models (:class:`WorldTrees`)
    MuJoCo's ``MjSpec`` walks its whole body tree again on every body, joint, geom or site added
    (MuJoCo 4.0 rebuilds its element lists and the tree's signature each time), so writing ``E``
    elements one by one costs ``O(E²)``: 1.3 s for 2 048 particles, 27 s for 8 192 (six
    elements each). Up to :data:`SPEC_DIRECT_BODIES` bodies the builders write straight into the
    spec; above it, :class:`WorldTrees` writes the world's trees of bodies into small scratch specs
    and assembles them with MuJoCo's ``attach`` (which moves elements, it does not copy them): the
    bodies of a 20 000-node plate in about 5 s, its whole spec in about 7 s (a shared two-core
    machine; ``scripts/bench_structure_scale.py``). The compiled ``MjModel`` is the same, array
    for array; the authored MJCF (``spec.to_xml()``) then holds each attached part in an unnamed
    identity ``<frame>`` (MuJoCo writes attached parts that way), which compiles to the same model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from magsail_mj.mjcf.common import INTEGRATORS, set_view

from magsail_mj.lattice.geometry import Lattice

__all__ = [
    "SPEC_CHUNK_BODIES",
    "SPEC_DIRECT_BODIES",
    "TrussModelOptions",
    "WorldTrees",
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
#: Largest model (bodies) written straight into its spec; larger ones go through :class:`WorldTrees`'s
#: scratch specs (module docstring). Every committed model (at most 1 568 bodies) is below it.
SPEC_DIRECT_BODIES = 2000
#: Bodies per scratch spec of :class:`WorldTrees` (a tree of more bodies has a spec of its own).
SPEC_CHUNK_BODIES = 64
_WORLD_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


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
    with WorldTrees(spec, n_bodies=n) as trees:
        for i in range(n):
            free = i not in fixed
            add_particle_node(
                trees.parent(1),
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


@dataclass
class _Receiver:
    """A spec that parts are attached to, the frame they go in (made at the first attach) and
    the scratch specs it holds."""

    spec: mujoco.MjSpec
    chunks: int = 1
    frame: mujoco.MjsFrame | None = None


class WorldTrees:
    """Writes the trees of bodies that hang from the world into a spec without MuJoCo's ``O(E²)``
    cost of adding ``E`` elements one by one (module docstring, "Large models").

    Use::

        with WorldTrees(spec, n_bodies=n) as trees:
            for each tree, in the order the world's children must have:
                root = trees.parent(tree_bodies).add_body(...)  # then the tree below ``root``

    A model of at most :data:`SPEC_DIRECT_BODIES` bodies is written straight into ``spec``
    (:meth:`parent` is ``spec.worldbody``). A larger one is written into scratch specs of about
    :data:`SPEC_CHUNK_BODIES` bodies (whole trees; a tree is never split), each with ``spec``'s
    compiler settings: an element added costs the size of its scratch spec, ``O(E c)`` in all for
    chunks of ``c`` elements. ``g ≈ √k`` consecutive ones of the ``k`` chunks make a group (the
    first receives the others), and on leaving the block the groups are attached to ``spec`` in
    order; MuJoCo appends an attached part to its new parent's children, so the bodies keep their
    order. An attach costs the size of the MjSpec receiving it, ``E √k`` for both levels together
    (about 1 s at 20 000 particles, ``k = 313``). Two levels and no more: MuJoCo looks each moved
    element's source spec up through the nested attaches, a search that grows with the nesting.

    The elements travel unnamed: an attach re-indexes every name of the MjSpec receiving it, which
    made a named attach cost 12 times an unnamed one (0.29 s against 0.023 s into 16 000
    particles); the names are recorded when a chunk is finished and set back when everything is in
    ``spec``. Every attach needs a name prefix all the same (an empty one makes MuJoCo warn on
    every compile), and copies the scratch spec's default class, deleted at once. Leave the block
    before adding anything that refers to the bodies by name (tendons, skins).
    """

    def __init__(self, spec: mujoco.MjSpec, *, n_bodies: int):
        self._spec = spec
        self._direct = int(n_bodies) <= SPEC_DIRECT_BODIES
        self._group_chunks = max(1, math.isqrt(-(-int(n_bodies) // SPEC_CHUNK_BODIES)))
        self._groups: list[_Receiver] = []
        self._chunk: mujoco.MjSpec | None = None
        self._bodies = 0  # bodies in the current chunk
        self._names: list[tuple[object, str]] = []
        self._attached = 0

    def __enter__(self) -> WorldTrees:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is None:
            self._close()

    def parent(self, n_bodies: int) -> mujoco.MjsBody:
        """The body the next tree of ``n_bodies`` bodies hangs from: the world of ``spec`` or of
        the current chunk (a new one when this tree would overfill it)."""
        if self._direct:
            return self._spec.worldbody
        if self._chunk is None or (self._bodies and self._bodies + n_bodies > SPEC_CHUNK_BODIES):
            self._finish_chunk()
            self._chunk = mujoco.MjSpec()
            self._chunk.compiler = self._spec.compiler
        self._bodies += int(n_bodies)
        return self._chunk.worldbody

    def _finish_chunk(self) -> None:
        """Take the current chunk's names off (recorded: they are set back at the end); the chunk
        starts a group or goes into the current one."""
        chunk, self._chunk, self._bodies = self._chunk, None, 0
        if chunk is None:
            return
        for elements in (chunk.bodies[1:], chunk.joints, chunk.geoms, chunk.sites, chunk.cameras, chunk.lights):
            named = [(element, element.name) for element in elements if element.name]
            for element, _ in named:
                element.name = ""
            self._names += named
        if not self._groups or self._groups[-1].chunks == self._group_chunks:
            self._groups.append(_Receiver(chunk))
        else:
            self._attach(self._groups[-1], chunk)
            self._groups[-1].chunks += 1

    def _attach(self, receiver: _Receiver, child: mujoco.MjSpec) -> None:
        """Attach ``child`` into ``receiver``'s frame and delete the default class it copied."""
        if receiver.frame is None:
            receiver.frame = receiver.spec.worldbody.add_frame()
        self._attached += 1
        prefix = f"attached{self._attached}_"
        receiver.spec.attach(child, prefix=prefix, frame=receiver.frame)
        receiver.spec.delete(receiver.spec.find_default(f"{prefix}main"))

    def _close(self) -> None:
        if self._direct:
            return
        self._finish_chunk()
        target = _Receiver(self._spec, chunks=0)
        for group in self._groups:
            self._attach(target, group.spec)
        self._groups.clear()
        for element, name in self._names:
            element.name = name
        self._names.clear()


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
    for ax, axis, free in zip("xyz", _WORLD_AXES, free_axes):
        if free:
            body.add_joint(
                name=f"n{index}_{ax}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=list(axis), damping=damping_Ns_m
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
