r"""MuJoCo model (``MjSpec``) of any :class:`~magsail_mj.structure.model.Structure`.

Frames and options
    The world frame is the structure frame at the reference configuration (positions are used as
    given; :attr:`StructureModelIndex.center_of_mass_m` says where the centre of mass is). Every
    body is world-aligned at the reference (no body quaternions). Gravity is off, contacts are
    disabled, and the arena is :func:`~magsail_mj.lattice.mjcf.lattice_arena_bytes` of ``nv``
    (plus the constraint solver's share when there are equality constraints, "Arena"); the
    options, view and light are those of :func:`~magsail_mj.lattice.mjcf.build_truss_spec`, whose
    node and tendon writers this module shares (a lattice of struts compiles to the same
    ``MjModel`` as the truss builder, given the same node radius and member width). The structure
    is expected to pass :func:`~magsail_mj.structure.checks.check_structure`; the builder itself
    refuses only what the model cannot hold. The bodies are written tree by tree through
    :class:`~magsail_mj.lattice.mjcf.WorldTrees`: above
    :data:`~magsail_mj.lattice.mjcf.SPEC_DIRECT_BODIES` bodies they are assembled from scratch
    specs (MuJoCo's spec costs ``O(E²)`` for ``E`` elements added one by one), which gives the
    same ``MjModel`` and an MJCF holding unnamed identity ``<frame>`` elements.

Bodies (:func:`~magsail_mj.structure.beams.body_layout`)
    *Particle* (a node no beam touches, no part holds): body ``n<i>`` at the node, three slide
    joints ``n<i>_x|y|z`` along the world axes (a fixed translation drops its joint; rotation
    constraints of a particle mean nothing and are ignored), its lumped mass
    (:meth:`Structure.lumped_masses`) on a non-colliding sphere geom, site ``s<i>``.
    *Beam node*: body ``n<i>`` at the node with an explicit inertia: its lumped mass and the
    rotational inertia of the lumped (HRZ) beam mass model
    (:func:`~magsail_mj.structure.beams.node_rotary_inertia`) plus that of a solid sphere of the
    node radius, ``2/5 m r²`` (which keeps a node of massless beams a valid rigid body); a
    tensor that still breaks the triangle inequality (beam segments shorter than about four
    section radii) is raised by the smallest isotropic term that restores it.
    *Rigid part*: body ``part_<name>`` with its origin at the part's ``center_m``; it holds its
    nodes as sites ``s<i>`` (and sphere geoms) and carries the part's mass and inertia plus its
    nodes' lumped masses (point masses) and beam rotational inertia, about their common centre.
    *Closing body* of a cut beam ``j`` ("Cycles"): body ``m<j>_close`` at its end node ``b``.
    Where ``k`` closing bodies sit at a node, the node's lumped mass and rotational inertia (and
    its sphere's) are shared equally between its own body (or its part's point mass) and them,
    ``1/(k + 1)`` each: the welded bodies together carry the node's mass properties unchanged.

Joints
    A tree's root hangs from the world. Free root: a free joint ``<body>_free``. Constrained root
    (``fixed_dofs`` of its constraining node ``a``): slide joints ``<body>_x|y|z`` for the free
    translations, then, about the node ``a``, a ball joint ``<body>_ball`` when no rotation is
    fixed or hinges ``<body>_rx|ry|rz`` about the world axes for the free rotations; nothing when
    all six are fixed (welded). A tree's other bodies hang from the body on the root side of their
    beam ``j`` (length ``l`` between the nodes, rest length ``l0``, member axes ``x, y, z`` of
    :func:`~magsail_mj.structure.assembly.beam_frames`) by four joints:

    ========================  =====================================  ==============================
    joint                     axis, anchor                           stiffness (spring reference)
    ========================  =====================================  ==============================
    ``m<j>_axial`` (slide)    member axis, parent → child            ``EA/l0`` (``l0 − l``)
    ``m<j>_twist`` (hinge)    ``x``, member midpoint                 ``GJ/l0``
    ``m<j>_bend1`` (hinge)    ``z``, member midpoint                 ``EI1/l0`` (plane 1, along y)
    ``m<j>_bend2`` (hinge)    ``y``, member midpoint                 ``EI2/l0`` (plane 2, along z)
    ========================  =====================================  ==============================

    Damping is stiffness-proportional: the slide carries the member's axial dashpot ``c``
    (``damping_Ns_m``, force ``−c l̇``), which is ``β = c l0 / EA`` [s] times its axial
    stiffness, and each hinge the joint damping ``β`` times its own stiffness (``β GJ/l0``,
    ``β EI1/l0``, ``β EI2/l0`` [N m s/rad]). A beam's damping is thus ``β`` times its stiffness
    in every joint (Rayleigh's stiffness-proportional damping), so a structure of beams with one
    ``β`` damps each of its modes with the ratio ``ζ_n = β ω_n / 2`` (a cantilever's first
    bending mode decays so in MuJoCo, ``tests/test_structure_mjcf.py``); a beam with ``EA = 0``
    has no ``β`` and its damping is refused. Each beam is thus two rigid halves
    joined at its midpoint by a spring of its whole bending (torsional) compliance ``l0/EI``
    (``l0/GJ``): axial and torsional chains are exact, and a cantilever of ``N`` equal beams under
    a tip force deflects ``P L³/(3 EI) · (1 − 1/(4 N²))`` (midpoint-rule quadrature of the moment;
    −0.0625 % at ``N = 20``; a hinge at each node with ``EI/l`` would give ``+ (3N + 1)/(2N²)``,
    +7.6 %).
    The three hinges compose as intrinsic rotations: exact for small relative rotations, and
    non-singular below 90° of bending per member.

    Every further constrained vertex of a tree (:mod:`magsail_mj.structure.beams`: a beam tree
    held at several places) is attached to the world at its constraining node by an equality
    constraint ``<body>_held`` with the closing welds' ``solref``/``solimp`` ("Cycles"): a weld
    when all six components are fixed, a ``connect`` (ball and socket) when the three
    translations are; other partial constraints can be held at one node of a tree only, its root.

    MuJoCo's native alternatives to the chain were not used: 1-D flexes (discrete elastic rods)
    bend only under ``Euler``, ``RK4`` and ``discrete`` (their bending elasticity refuses
    ``implicit``/``implicitfast``; checked with MuJoCo 4.0.0), hold only open chains or rings (not
    branching trees or rigid parts in a chain) and stretch only by per-flex edge springs; the
    ``mujoco.elasticity.cable`` plugin is not shipped in the wheel (``plugin
    mujoco.elasticity.cable not found``).

Cycles (closed beam loops: a hoop, a frame cell)
    The bodies form a spanning tree of each connected beam graph; each beam ``j`` outside it (one
    per independent cycle) is cut at its end node ``b`` (:mod:`magsail_mj.structure.beams`): its
    closing body ``m<j>_close`` sits at ``b``, hangs from the body of its other end by the beam's
    own four joints (the table above, named as for any beam: the member is the same spring), and
    a weld equality ``m<j>_weld`` holds it to the body of ``b`` (anchor at ``b``, relative pose
    from the reference), carrying force and moment as the beam's continuous section at ``b``
    does. The weld is as stiff as MuJoCo allows at the model's time step ``h``:
    ``solimp = CLOSURE_SOLIMP`` (impedance ``d = 0.9999``, MuJoCo's largest, at any violation)
    and ``solref = (2 h, 1)`` (the shortest time constant MuJoCo accepts, critically damped). A
    soft equality at rest acts as a spring of stiffness ``1 / ((1 − d) d τ² A)`` per row (``A``
    the row's inverse effective mass, ``τ`` the time constant), so with these values the weld is
    a negligible compliance in series with the beams: a free ring of 24 beams keeps the
    frequencies of its exact-weld modes within 1e-6 in MuJoCo's linearised step, a ring of 48 its
    pinched deflection within 4e-6, where MuJoCo's default ``solref = (0.02, 1)``,
    ``solimp = (0.9, 0.95, …)`` lowers the first frequency by 38 % (``tests/test_structure_hoop.py``).
    The constraint modes sit at ``1/τ = 1/(2h)``, so ``ω h = 0.5``: stable for every integrator.
    A ring of ``N`` straight beams standing for a circle is stiffer in its plane than the circle
    by ``O((π/N)²)`` (the chain ties each member's transverse displacement to its end rotations'
    mean, which a curved member does not obey): +2.2 % and +3.4 % for the first two in-plane
    bending frequencies and −4.3 % pinched deflection at ``N = 24``, a quarter of that at 48;
    out of its plane within 0.6 %.

Arena
    With equality constraints, MuJoCo's Newton solver factorises ``H = M + Jᵀ D J`` in the
    reverse dof order: a weld's Jacobian rows span the dofs of both its bodies' chains down to the
    root, so ``H`` and its factor fill in over the closed chains (dense over a ring's dofs). The
    arena gets :data:`CONSTRAINT_ARENA_MARGIN` times ``16 nnz(H) + 20 nnz(L) + 24 nnz(J) + 512
    n_efc`` bytes more (``H`` takes a value and two column indices an entry, its factor ``L`` a
    value and three), with ``nnz(H)`` and ``nnz(L)`` from a symbolic factorisation of the body
    graph in MuJoCo's order (SuperLU without pivoting, the constraint rows eliminated first to make
    their cliques): a ring of 200 beams (806 dofs) gets 30 MB and uses 18 MB, a grid of 15 × 15
    beam cells (1 926 dofs, 225 welds) 32 MB for 18 MB. A long chain's mass matrix is itself
    nearly dense (every dof couples with its ancestors), so the welds add little to a step's cost:
    0.18 s for that ring against 0.16 s for the same 200 beams as an open chain (one shared core).
    Many cycles cost more: a grid of 20 × 20 beam cells (400 welds, 1 600 dofs of closing bodies)
    steps in 85 ms against 12 ms for its spanning tree alone.

Tendons
    A strut ``j``: spatial tendon ``t<j>`` between the node sites, stiffness ``EA/l0``, damping
    ``c``, ``springlength = [l0, l0]`` (force ``−k (L − l0) − c L̇``). A cable: the same with
    ``springlength = [0, l0]``, MuJoCo's dead band: no spring force while ``L ≤ l0``. MuJoCo's
    tendon damping acts whatever the length, so a damped slack cable would push while it
    shortens; a cable must therefore have ``damping_Ns_m = 0`` (refused otherwise) and never
    pushes.

Flex struts (``strut_elements``)
    MuJoCo computes each tendon's ``tendon_invweight0`` at compile with a dense ``nv``-vector
    solve, so a model of tendons compiles in ``O(ntendon · nv)``: quadratic in the node count of
    a lattice (``scripts/bench_structure_scale.py``). A 1-D flex edge between two bodies
    whose joints are all slides (MuJoCo's "simple" bodies, ``body_simple == 2``) takes an ``O(1)``
    path for its ``flexedge_invweight0``. A flex's edges share one stiffness ``k`` and damping
    ``c`` (MuJoCo's ``<edge stiffness damping>``: passive force ``−k (L − L0) − c L̇`` along the
    edge, ``L0`` the edge's length at ``qpos0``; its energy ``½ k (L − L0)²`` is in MuJoCo's
    potential energy), so the qualifying struts are written as one flex ``struts<g>`` per
    distinct ``(EA/l0, c)`` (a lattice has a handful), vertices on the particle bodies, every
    edge non-colliding (``contype = conaffinity = 0``, no self-collision) and drawn as a tendon
    is (radius the member width). A strut qualifies when both its ends are particles, its rest
    length is its length at the reference (no prestrain; within :data:`FLEX_REST_RTOL`), the
    structure's stiffness model is ``"members"``, and no other qualifying strut joins the same
    two nodes (MuJoCo merges repeated edges into one); cables (their dead band is the tendon's
    spring range), beams and all others stay tendons. Under ``Euler`` and ``RK4`` the flex law
    is the tendon's, step for step: a lattice's trajectory is the same to rounding (1e-12 over
    200 steps; ``L0`` is MuJoCo's reference length and the forces are summed in another order;
    ``tests/test_structure_flex.py``). Under ``implicit``/``implicitfast`` MuJoCo integrates
    tendon damping implicitly but flex edge damping explicitly, so a damped lattice moves
    differently (stable only while ``c h / m`` is small). ``strut_elements``: ``"tendons"``
    (every strut a tendon), ``"flex"`` (every qualifying strut a flex edge, any integrator) or
    ``"auto"`` (the default): flexes when the integrator is ``Euler`` or ``RK4`` and ``ntendon ·
    nv`` of the all-tendon model exceeds :data:`FLEX_AUTO_TENDON_DOFS` (1e8, about 0.1 s of
    compile; the largest shipped lattice has 3.2e7, so every shipped model keeps its tendons and
    its stored results), else tendons. :class:`StructureModelIndex` gives each member's tendon or
    flex edge (``flexedge_length`` is its length); member lengths, strains and energies are
    computed from the node positions and the member table either way.

Drawn beams and rigid parts
    Visual only (``visual_geoms``): geoms in group :data:`VISUAL_GROUP` with ``contype =
    conaffinity = 0`` and no mass, on bodies whose inertials are explicit, so that they change
    no mass, inertia, dof or force (``tests/test_structure_visuals.py`` compares the arrays). Each
    beam is drawn as its model is, two rigid halves meeting at its midpoint: a capsule from the
    parent-side node to the midpoint in the parent body's frame, and one from the midpoint to the
    other node in the child's (or closing) body's frame. The member table holds rigidities, not a
    section, so the capsules' radius is :data:`BEAM_RADIUS_OF_WIDTH` times the drawn member width
    (3 % of the median member rest length by default). A rigid part is a box about its centre
    along the principal axes of its own inertia ``I₁, I₂, I₃``: the box of uniform density with
    the part's mass ``m`` and those moments, half-sides ``a_k = √(3 (I₁ + I₂ + I₃) / (2 m) −
    3 I_k / m)`` (from ``I₁ = m (b² + c²) / 3``); where that is degenerate (no mass, a zero
    half-side) the bounding box of its nodes about their mean. Each half-side is then enlarged
    to at least half a node radius and the box scaled up uniformly until its largest half-side is
    :data:`PART_MIN_HALF_OF_RADIUS` node radii: a 20 kg hub on a 100 m sail is a box under 1 m,
    smaller than its own node sphere otherwise.

Panels
    Drawn only: one MuJoCo skin ``panels`` (rendering-only by MuJoCo's definition: no dofs, no
    forces, no mass) whose vertices are bound to the bodies of the panels' corner nodes, each
    panel drawn on both faces (MuJoCo skins are one-sided). Their mass is already in the nodes.

Damping per node (``node_damping_1_s``)
    ``a = −c v`` on particles (slide-joint damping ``c m_i``), as in the truss builder. Joint
    damping of a chain is relative motion, not absolute, so a structure with beams or rigid
    parts refuses a non-zero value.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy import sparse
from scipy.sparse.linalg import splu

from magsail_mj.lattice.mjcf import (
    WorldTrees,
    add_node_sphere,
    add_particle_node,
    STRUT_RGBA,
    add_spring_tendon,
    lattice_arena_bytes,
    truss_base_spec,
)
from magsail_mj.structure.assembly import beam_frames
from magsail_mj.structure.beams import BEAM_NODE, PART, PARTICLE, BodyLayout, body_layout, node_rotary_inertia
from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError

__all__ = [
    "BEAM_JOINTS",
    "BEAM_RADIUS_OF_WIDTH",
    "BEAM_RGBA",
    "FLEX_AUTO_TENDON_DOFS",
    "FLEX_REST_RTOL",
    "CLOSURE_SOLIMP",
    "CLOSURE_TIMECONST_STEPS",
    "CONSTRAINT_ARENA_MARGIN",
    "PANEL_RGBA",
    "PART_MIN_HALF_OF_RADIUS",
    "PART_RGBA",
    "STRUT_ELEMENTS",
    "StructureModelIndex",
    "VISUAL_GROUP",
    "build_structure_spec",
    "closing_body_name",
    "flex_struts",
    "part_body_name",
    "part_box",
]

PANEL_RGBA = (0.80, 0.68, 0.35, 1.0)
BEAM_RGBA = (0.72, 0.74, 0.80, 1.0)
PART_RGBA = (0.32, 0.38, 0.50, 1.0)
#: Geom group of the drawn beams and rigid parts (MuJoCo draws groups 0–2 by default).
VISUAL_GROUP = 2
#: A drawn beam's radius over the drawn member width (module docstring, "Drawn beams").
BEAM_RADIUS_OF_WIDTH = 2.0
#: The smallest largest half-side of a drawn rigid part, in node radii.
PART_MIN_HALF_OF_RADIUS = 3.0
_CABLE = MEMBER_KINDS.index("cable")
_BEAM = MEMBER_KINDS.index("beam")
_STRUT = MEMBER_KINDS.index("strut")
#: The ways struts are built (module docstring, "Flex struts").
STRUT_ELEMENTS = ("auto", "tendons", "flex")
#: ``ntendon · nv`` of the all-tendon model above which ``"auto"`` builds flex struts.
FLEX_AUTO_TENDON_DOFS = 1.0e8
#: Largest ``|l − l0| / l0`` of a strut built as a flex edge (whose rest length is its reference length).
FLEX_REST_RTOL = 1e-12
_FLEX_AUTO_INTEGRATORS = ("Euler", "RK4")
_FLEX_PREFIX = "struts"
_AXES = "xyz"
#: The joints of a beam, in their order in the child body (module docstring).
BEAM_JOINTS = ("axial", "twist", "bend1", "bend2")
#: Impedance of the closing welds and of the world attachments (MuJoCo ``solimp``: ``d`` = 0.9999
#: at any violation, MuJoCo's largest; module docstring, "Cycles").
CLOSURE_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
#: Factor on the arena the constraint solver's matrices take (module docstring, "Arena").
CONSTRAINT_ARENA_MARGIN = 1.5
#: Time constant of those constraints in time steps (MuJoCo ``solref = (2 h, 1)``: critically
#: damped at the shortest time constant MuJoCo accepts, ``2 h``).
CLOSURE_TIMECONST_STEPS = 2.0


def part_body_name(name: str) -> str:
    """The body name of rigid part ``name``."""
    return f"part_{name}"


def closing_body_name(member: int) -> str:
    """The body name of the closing body of cut beam ``member`` (module docstring, "Cycles")."""
    return f"m{member}_close"


@dataclass(frozen=True)
class _Geometry:
    """What the writers share: layout, positions, masses and sizes."""

    structure: Structure
    layout: BodyLayout
    origin_m: np.ndarray  # (V, 3) body origins, world frame
    masses_kg: np.ndarray  # (n,) lumped, each body's share (closing bodies share their node's)
    rotary_kg_m2: np.ndarray  # (n, 3, 3), each body's share
    frames: np.ndarray  # (m, 3, 3) member axes (rows x, y, z); beams only, zeros elsewhere
    radius_m: float
    width_m: float
    node_damping_1_s: float
    visual_geoms: bool

    def body_name(self, vertex: int) -> str:
        n = self.structure.n_nodes
        return f"n{vertex}" if vertex < n else part_body_name(self.structure.rigid_parts[vertex - n].name)


def _extent_m(positions_m: np.ndarray) -> float:
    """The largest side of the nodes' bounding box [m] (1 m for a single point)."""
    extent = float(np.ptp(positions_m, axis=0).max()) if len(positions_m) else 0.0
    return extent if extent > 0 else 1.0


def _check(structure: Structure, layout: BodyLayout, masses: np.ndarray, node_damping_1_s: float) -> None:
    """Refuse damped cables, damped beams without EA, node damping with chains, and massless moving bodies."""
    members = structure.members
    problems = [
        f"members[{j}].damping_Ns_m: a cable carries no dashpot (MuJoCo's tendon damping would push while a slack "
        f"cable shortens), got {members.damping_Ns_m[j]!r}"
        for j in np.flatnonzero((members.kind == _CABLE) & (members.damping_Ns_m != 0))[:10]
    ]
    problems += [
        f"members[{j}].damping_Ns_m: a beam's damping is β = c l0 / EA times each joint's stiffness, so it needs "
        f"EA_N > 0, got damping {members.damping_Ns_m[j]!r} with EA_N = 0"
        for j in np.flatnonzero((members.kind == _BEAM) & (members.damping_Ns_m != 0) & ~(members.EA_N > 0))[:10]
    ]
    if structure.stiffness_model != "members":
        problems += [
            f"members[{j}].kind: the linear stiffness model {structure.stiffness_model!r} holds struts only, got "
            f"{MEMBER_KINDS[members.kind[j]]!r}"
            for j in np.flatnonzero(members.kind != MEMBER_KINDS.index("strut"))[:10]
        ]
    if not (np.isfinite(node_damping_1_s) and node_damping_1_s >= 0):
        problems.append(f"node_damping_1_s: must be finite and >= 0, got {node_damping_1_s!r}")
    elif node_damping_1_s > 0 and np.any(layout.kind != PARTICLE):
        problems.append(
            f"node_damping_1_s: applies to particles only (slide joints), got {node_damping_1_s!r} for a structure "
            "with beams or rigid parts (joint damping in a chain is relative, not absolute)"
        )
    n = structure.n_nodes
    fixed = np.asarray(structure.fixed_dofs, dtype=bool)
    moving_particle = (layout.kind[:n] == PARTICLE) & ~fixed[:, :3].all(axis=1)
    moving_node = (layout.kind[:n] == BEAM_NODE) & ~(fixed.all(axis=1) & (layout.parent[:n] < 0))
    problems += [
        f"node_mass_kg: node {i} moves (it has joints) but its lumped mass is {masses[i]!r} kg"
        for i in np.flatnonzero((moving_particle | moving_node) & ~(masses > 0))[:10]
    ]
    welded = (layout.parent < 0) & layout.root_fixed.all(axis=1)
    for p, part in enumerate(structure.rigid_parts):
        total = part.mass_kg + masses[np.asarray(part.nodes, dtype=np.int64)].sum()
        if not welded[n + p] and not total > 0:
            problems.append(
                f"rigid_parts[{p}] ({part.name!r}).mass_kg: the part moves but it and its nodes weigh {total!r} kg"
            )
    if problems:
        raise StructureError(problems)


def _balanced(inertia: np.ndarray) -> np.ndarray:
    """``inertia`` (k, 3, 3) plus the smallest isotropic term that makes its principal moments
    obey the triangle inequality ``I_max ≤ I_a + I_b``."""
    moments = np.linalg.eigvalsh(inertia)
    deficit = moments[:, 2] - moments[:, 0] - moments[:, 1]
    # a few ulps beyond equality: landing exactly on it, rounding tipped MuJoCo's A + B >= C check
    added = np.where(deficit > 0, deficit + 8 * np.finfo(float).eps * moments[:, 2], 0.0)
    return inertia + added[:, None, None] * np.eye(3)


def _shifted(mass: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """(k, 3, 3) inertia of point masses ``mass`` at ``offset`` (k, 3) about the origin."""
    r2 = np.einsum("ij,ij->i", offset, offset)
    return mass[:, None, None] * (r2[:, None, None] * np.eye(3) - offset[:, :, None] * offset[:, None, :])


def _set_inertial(body: mujoco.MjsBody, mass_kg: float, center_m: np.ndarray, inertia: np.ndarray) -> None:
    """Explicit inertial: mass, centre (body frame) and full inertia about it."""
    body.explicitinertial = True
    body.mass = float(mass_kg)
    body.ipos = [float(x) for x in center_m]
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]


def _node_inertial(g: _Geometry, body: mujoco.MjsBody, node: int) -> None:
    m = g.masses_kg[node]
    sphere = 0.4 * m * g.radius_m**2 * np.eye(3)
    _set_inertial(body, m, np.zeros(3), _balanced((g.rotary_kg_m2[node] + sphere)[None])[0])


def _part_inertial(g: _Geometry, body: mujoco.MjsBody, p: int) -> None:
    part = g.structure.rigid_parts[p]
    nodes = np.asarray(part.nodes, dtype=np.int64)
    origin = np.asarray(part.center_m, dtype=float)
    mass = np.append(g.masses_kg[nodes], part.mass_kg)
    where = np.vstack([g.structure.positions_m[nodes], origin])
    total = float(mass.sum())
    center = mass @ where / total if total > 0 else origin
    inertia = np.asarray(part.inertia_kg_m2, dtype=float) + _shifted(mass, where - center).sum(axis=0)
    inertia = inertia + g.rotary_kg_m2[nodes].sum(axis=0)
    _set_inertial(body, total, center - origin, _balanced(inertia[None])[0])


def _root_joints(g: _Geometry, body: mujoco.MjsBody, vertex: int) -> int:
    """Joints of a tree root (module docstring); returns its dof count."""
    name = g.body_name(vertex)
    anchor = g.layout.anchor_node[vertex]
    if anchor < 0:
        body.add_freejoint(name=f"{name}_free")
        return 6
    fixed = g.layout.root_fixed[vertex]
    pivot = [float(x) for x in g.structure.positions_m[anchor] - g.origin_m[vertex]]
    axes = np.eye(3)
    for k in np.flatnonzero(~fixed[:3]):
        body.add_joint(name=f"{name}_{_AXES[k]}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axes[k].tolist())
    if not fixed[3:].any():
        body.add_joint(name=f"{name}_ball", type=mujoco.mjtJoint.mjJNT_BALL, pos=pivot)
        return int((~fixed[:3]).sum()) + 3
    for k in np.flatnonzero(~fixed[3:]):
        body.add_joint(name=f"{name}_r{_AXES[k]}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=axes[k].tolist(), pos=pivot)
    return int((~fixed).sum())


def _beam_joints(g: _Geometry, body: mujoco.MjsBody, j: int, start: int, origin_m: np.ndarray) -> int:
    """The four joints of beam ``j`` in ``body`` (origin ``origin_m``, world frame), which hangs
    from the body holding node ``start`` of the beam (module docstring)."""
    members = g.structure.members
    ends = members.nodes[j]
    end = ends[1] if ends[0] == start else ends[0]
    p = g.structure.positions_m
    length = float(np.linalg.norm(p[end] - p[start]))
    l0 = float(members.rest_length_m[j])
    x, y, z = g.frames[j]
    mid = [float(c) for c in 0.5 * (p[start] + p[end]) - origin_m]
    hinge = mujoco.mjtJoint.mjJNT_HINGE
    axial = float(members.EA_N[j] / l0)
    beta = float(members.damping_Ns_m[j]) / axial if axial > 0 else 0.0  # β = c l0 / EA [s]
    body.add_joint(
        name=f"m{j}_axial",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=((p[end] - p[start]) / length).tolist(),
        stiffness=axial,
        springref=l0 - length,
        damping=float(members.damping_Ns_m[j]),
    )
    for name, axis, rigidity in (
        ("twist", x, members.GJ_Nm2[j]),
        ("bend1", z, members.EI_Nm2[j, 0]),
        ("bend2", y, members.EI_Nm2[j, 1]),
    ):
        k = float(rigidity / l0)
        body.add_joint(name=f"m{j}_{name}", type=hinge, axis=axis.tolist(), pos=mid, stiffness=k, damping=beta * k)
    return 4


def _held_sites(g: _Geometry, body: mujoco.MjsBody, vertex: int, nodes: np.ndarray) -> None:
    """Sphere geoms (massless: the inertial is explicit) and sites of the nodes a body holds."""
    for i in nodes.tolist():
        offset = g.structure.positions_m[i] - g.origin_m[vertex]
        add_node_sphere(body, mass_kg=0.0, radius_m=g.radius_m, pos_m=offset)
        body.add_site(name=f"s{i}", pos=[float(c) for c in offset], size=[g.radius_m * 0.5, 0, 0], group=5)


def _trees(layout: BodyLayout) -> tuple[np.ndarray, np.ndarray]:
    """The write order tree by tree (trees in the order of their roots in ``layout.order``, each
    tree's vertices in layout order: every body keeps its children's order) and the body count of
    each tree, closing bodies included (at its root's index)."""
    V = layout.kind.size
    root = np.where(layout.parent < 0, np.arange(V), layout.parent)
    while True:  # pointer jumping: log₂ of the deepest tree's depth passes
        up = root[root]
        if np.array_equal(up, root):
            break
        root = up
    order = layout.order
    rank = np.empty(V, dtype=np.int64)
    rank[order] = np.arange(order.size)
    by_tree = order[np.argsort(rank[root[order]], kind="stable")]
    counts = np.bincount(root[order], minlength=V) + np.bincount(root[layout.cut_parent], minlength=V)
    return by_tree, counts


def _write_bodies(g: _Geometry, spec: mujoco.MjSpec) -> np.ndarray:
    """All bodies and joints, tree by tree (:class:`~magsail_mj.lattice.mjcf.WorldTrees`); returns
    the dofs of each vertex's body (V,), closing bodies' dofs at their parent vertex."""
    bodies: dict[int, mujoco.MjsBody] = {}
    fixed = np.asarray(g.structure.fixed_dofs, dtype=bool)
    order, tree_bodies = _trees(g.layout)
    held = np.argsort(g.layout.node_vertex, kind="stable")  # the nodes of each vertex, in node order
    held_start = np.searchsorted(g.layout.node_vertex[held], np.arange(g.layout.kind.size + 1))
    closing = np.argsort(g.layout.cut_parent, kind="stable")  # the cuts hanging from each vertex
    closing_start = np.searchsorted(g.layout.cut_parent[closing], np.arange(g.layout.kind.size + 1))
    dofs = np.zeros(g.layout.kind.size, dtype=np.int64)
    with WorldTrees(spec, n_bodies=order.size) as trees:
        for v in order.tolist():
            kind = g.layout.kind[v]
            parent = g.layout.parent[v]
            holder = trees.parent(int(tree_bodies[v])) if parent < 0 else bodies[parent]
            if kind == PARTICLE:
                free = ~fixed[v, :3]
                bodies[v] = add_particle_node(
                    holder,
                    index=v,
                    pos_m=g.origin_m[v],
                    mass_kg=float(g.masses_kg[v]),
                    free_axes=tuple(bool(f) for f in free),
                    damping_Ns_m=float(g.node_damping_1_s * g.masses_kg[v]),
                    radius_m=g.radius_m,
                )
                dofs[v] = int(free.sum())
                continue
            rel = g.origin_m[v] - (g.origin_m[parent] if parent >= 0 else 0.0)
            body = holder.add_body(name=g.body_name(v), pos=[float(c) for c in rel])
            if parent < 0:
                dofs[v] = _root_joints(g, body, v)
            else:
                j = g.layout.parent_member[v]
                dofs[v] = _beam_joints(g, body, j, g.structure.members.nodes[j, g.layout.parent_end[j]], g.origin_m[v])
            if kind == PART:
                _part_inertial(g, body, v - g.structure.n_nodes)
            else:
                _node_inertial(g, body, v)
            _held_sites(g, body, v, held[held_start[v] : held_start[v + 1]])
            if kind == PART:
                _part_visual(g, body, v - g.structure.n_nodes)
            if parent >= 0:
                j = g.layout.parent_member[v]
                start = g.structure.members.nodes[j, g.layout.parent_end[j]]
                _beam_visual(g, j, start, (bodies[parent], g.origin_m[parent]), (body, g.origin_m[v]))
            bodies[v] = body
            for k in closing[closing_start[v] : closing_start[v + 1]].tolist():
                dofs[v] += _closing_body(g, body, k)
    return dofs


def _body_tree(layout: BodyLayout, dofs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The model's bodies in MuJoCo's order (depth first, children in the order they were added:
    a body's closing bodies, then its tree children): their parent (−1 the world) and dofs, the
    body of each vertex (−1 for ``HELD``) and of each closing body."""
    order, _ = _trees(layout)
    cuts = layout.cut_member.size
    by_parent = np.argsort(layout.cut_parent, kind="stable")
    start = np.searchsorted(layout.cut_parent[by_parent], np.arange(layout.kind.size + 1))
    children: dict[int, list[int]] = {-1: []}  # items: vertex v, or closing body k as V + k
    V = layout.kind.size
    for v in order.tolist():
        children.setdefault(int(layout.parent[v]), []).append(v)
        children[v] = [V + int(k) for k in by_parent[start[v] : start[v + 1]]]
    own = dofs - np.bincount(layout.cut_parent, minlength=V) * len(BEAM_JOINTS)
    item_dofs = np.concatenate([own, np.full(cuts, len(BEAM_JOINTS))])
    body = np.full(V + cuts, -1, dtype=np.int64)
    parent, body_dofs = [], []
    stack = [(item, -1) for item in reversed(children[-1])]
    while stack:
        item, up = stack.pop()
        body[item] = len(parent)
        parent.append(up)
        body_dofs.append(int(item_dofs[item]))
        stack.extend((child, body[item]) for child in reversed(children.get(item, [])))
    return np.array(parent, dtype=np.int64), np.array(body_dofs, dtype=np.int64), body[:V], body[V:]


def _constraint_arena_bytes(layout: BodyLayout, dofs: np.ndarray) -> int:
    """Arena [bytes] MuJoCo's Newton solver takes for the closing welds and world attachments
    (module docstring, "Arena"), from a symbolic factorisation of ``H = M + JᵀJ`` body by body;
    0 without them."""
    cuts, held = layout.cut_member.size, layout.held_vertex.size
    if cuts + held == 0:
        return 0
    parent, body_dofs, vertex_body, closing_body = _body_tree(layout, dofs)
    B = parent.size
    # Anc[x, a]: a is x or one of its ancestors (pointer walk, one level a pass)
    rows, cols = [np.arange(B)], [np.arange(B)]
    up = parent.copy()
    while np.any(up >= 0):
        at = np.flatnonzero(up >= 0)
        rows.append(at)
        cols.append(up[at])
        up = np.where(up >= 0, parent[np.maximum(up, 0)], -1)
    ancestors = sparse.csr_matrix(
        (np.ones(sum(r.size for r in rows)), (np.concatenate(rows), np.concatenate(cols))), (B, B)
    )
    # each constraint's rows span the chains of its two bodies (the world has none)
    ends = [
        (np.arange(cuts), closing_body),
        (np.arange(cuts), vertex_body[layout.node_vertex[layout.cut_node]]),
        (cuts + np.arange(held), vertex_body[layout.held_vertex]),
    ]
    K = cuts + held
    E = sparse.csr_matrix(
        (np.ones(2 * cuts + held), (np.concatenate([e[0] for e in ends]), np.concatenate([e[1] for e in ends]))),
        (K, B),
    )
    support = ((E @ ancestors) > 0).astype(float).tocsr()  # (K, B)
    moving = np.flatnonzero(body_dofs > 0)
    support, ancestors = support[:, moving], ancestors[moving][:, moving]
    weight = body_dofs[moving].astype(float)
    row_dofs = np.append(np.full(cuts, 6), np.where(layout.held_weld, 6, 3))
    jacobian_nonzeros = int(row_dofs @ (support @ weight))
    mass = ((ancestors + ancestors.T) > 0).astype(float)
    hessian = ((support.T @ support + mass) > 0).astype(float).tocoo()
    hessian_nonzeros = int(weight[hessian.row] @ weight[hessian.col])
    # symbolic factor in MuJoCo's order (the last dof first): the constraint nodes eliminated first
    # make the cliques of JᵀJ, then the bodies in reverse; random values, so that nothing cancels
    m = moving.size
    rng = np.random.default_rng(0)
    lower = sparse.tril(mass, k=-1).tocoo()
    values = sparse.coo_matrix((rng.uniform(0.1, 1.0, lower.nnz), (lower.row, lower.col)), (m, m))
    body_block = values + values.T + sparse.identity(m) * (10.0 * (K + m))
    coupling = support.tocoo()
    coupling = sparse.coo_matrix((rng.uniform(0.1, 1.0, coupling.nnz), (coupling.row, coupling.col)), (K, m))
    augmented = sparse.bmat([[-sparse.identity(K), coupling], [coupling.T, body_block]]).tocsc()
    reverse = np.r_[np.arange(K), K + np.arange(m)[::-1]]
    factor = splu(
        augmented[reverse][:, reverse], permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )
    L = factor.L.tocoo()  # of the ordered matrix permuted: row q is its row inv_r[q], column p its inv_c[p]
    below = L.row > L.col
    node_i = np.argsort(factor.perm_r)[L.row[below]]
    node_j = np.argsort(factor.perm_c)[L.col[below]]
    both = (node_i >= K) & (node_j >= K)
    ordered = weight[::-1]  # dofs of the ordered bodies
    factor_nonzeros = int(ordered[node_i[both] - K] @ ordered[node_j[both] - K])
    factor_nonzeros += int((weight * (weight + 1) // 2).sum())
    need = 16 * hessian_nonzeros + 20 * factor_nonzeros + 24 * jacobian_nonzeros + 512 * int(row_dofs.sum())
    return int(CONSTRAINT_ARENA_MARGIN * need)


def _closing_body(g: _Geometry, parent: mujoco.MjsBody, k: int) -> int:
    """The closing body of cut ``k`` (module docstring, "Cycles") in ``parent``; returns its dofs."""
    j = int(g.layout.cut_member[k])
    node = int(g.layout.cut_node[k])
    ends = g.structure.members.nodes[j]
    start = int(ends[1] if ends[0] == node else ends[0])
    vertex = int(g.layout.cut_parent[k])
    where = g.structure.positions_m[node]
    body = parent.add_body(name=closing_body_name(j), pos=[float(c) for c in where - g.origin_m[vertex]])
    _node_inertial(g, body, node)
    dofs = _beam_joints(g, body, j, start, where)
    _beam_visual(g, j, start, (parent, g.origin_m[vertex]), (body, where))
    return dofs


def _visual_geom(body: mujoco.MjsBody, **attributes) -> None:
    """A drawn-only geom (module docstring, "Drawn beams and rigid parts")."""
    body.add_geom(contype=0, conaffinity=0, mass=0.0, group=VISUAL_GROUP, **attributes)


def _beam_visual(
    g: _Geometry,
    j: int,
    start: int,
    parent: tuple[mujoco.MjsBody, np.ndarray],
    child: tuple[mujoco.MjsBody, np.ndarray],
) -> None:
    """Beam ``j``'s two drawn halves: node ``start`` to the midpoint in the parent body, the
    midpoint to the other node in the child body (each given with its origin, world frame)."""
    if not g.visual_geoms:
        return
    ends = g.structure.members.nodes[j]
    end = ends[1] if ends[0] == start else ends[0]
    p = g.structure.positions_m
    mid = 0.5 * (p[start] + p[end])
    radius = BEAM_RADIUS_OF_WIDTH * g.width_m
    for (body, origin), a, b in ((parent, p[start], mid), (child, mid, p[end])):
        _visual_geom(
            body,
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            size=[radius, 0.0, 0.0],
            fromto=[*(float(c) for c in a - origin), *(float(c) for c in b - origin)],
            rgba=list(BEAM_RGBA),
        )


def part_box(structure: Structure, p: int, *, radius_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drawn box of rigid part ``p`` (module docstring, "Drawn beams and rigid parts"): its
    centre (3,) [m] and axes (3, 3, columns) in the structure frame, and its half-sides (3,) [m];
    ``radius_m`` is the node radius."""
    part = structure.rigid_parts[p]
    mass = float(part.mass_kg)
    moments, axes = np.linalg.eigh(np.asarray(part.inertia_kg_m2, dtype=float))
    center = np.asarray(part.center_m, dtype=float)
    squares = 1.5 * moments.sum() / mass - 3.0 * moments / mass if mass > 0 else np.zeros(3)
    if not np.all(squares > 0):  # no mass, a flat or inconsistent inertia: the nodes' extent
        held = structure.positions_m[np.asarray(part.nodes, dtype=np.int64)].reshape(-1, 3)
        low, high = (held.min(axis=0), held.max(axis=0)) if len(held) else (center, center)
        center, axes, half = 0.5 * (low + high), np.eye(3), 0.5 * (high - low)
    else:
        half = np.sqrt(squares)
    half = np.maximum(half, 0.5 * radius_m)
    half = half * max(1.0, PART_MIN_HALF_OF_RADIUS * radius_m / half.max())
    return center, axes, half


def _part_visual(g: _Geometry, body: mujoco.MjsBody, p: int) -> None:
    """Rigid part ``p``'s drawn box in its body (origin at the part's ``center_m``)."""
    if not g.visual_geoms:
        return
    center, axes, half = part_box(g.structure, p, radius_m=g.radius_m)
    if np.linalg.det(axes) < 0:
        axes = axes * np.array([1.0, 1.0, -1.0])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(axes).ravel())
    _visual_geom(
        body,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=half.tolist(),
        pos=[float(c) for c in center - np.asarray(g.structure.rigid_parts[p].center_m, dtype=float)],
        quat=quat.tolist(),
        rgba=list(PART_RGBA),
    )


def _write_constraints(g: _Geometry, spec: mujoco.MjSpec) -> None:
    """The closing welds and the world attachments of held vertices (module docstring, "Cycles",
    "Joints"), each at its node, with ``solref = (CLOSURE_TIMECONST_STEPS · h, 1)`` and
    :data:`CLOSURE_SOLIMP`; MuJoCo computes the relative pose from the reference configuration."""
    layout, p = g.layout, g.structure.positions_m
    solref = [CLOSURE_TIMECONST_STEPS * float(spec.option.timestep), 1.0]
    weld, connect = mujoco.mjtEq.mjEQ_WELD, mujoco.mjtEq.mjEQ_CONNECT
    for j, node in zip(layout.cut_member.tolist(), layout.cut_node.tolist()):
        vertex = int(layout.node_vertex[node])
        anchor = p[node] - g.origin_m[vertex]  # in the frame of body 2, the node's body
        spec.add_equality(
            name=f"m{j}_weld",
            type=weld,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1=closing_body_name(j),
            name2=g.body_name(vertex),
            data=[*(float(c) for c in anchor), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            solref=solref,
            solimp=list(CLOSURE_SOLIMP),
        )
    for vertex, welded in zip(layout.held_vertex.tolist(), layout.held_weld.tolist()):
        node = int(layout.anchor_node[vertex])
        name = g.body_name(vertex)
        if welded:  # anchor in body 2, the world
            anchor, kind = p[node], weld
        else:  # anchor in body 1, the vertex's body
            anchor, kind = p[node] - g.origin_m[vertex], connect
        spec.add_equality(
            name=f"{name}_held",
            type=kind,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1=name,
            name2="world",
            data=[*(float(c) for c in anchor), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            solref=solref,
            solimp=list(CLOSURE_SOLIMP),
        )


def flex_struts(structure: Structure) -> np.ndarray:
    """(m,) which members may be built as flex edges (module docstring, "Flex struts"): struts
    between two particles at their rest length, under the ``"members"`` stiffness model, each the
    only such strut between its two nodes."""
    members = structure.members
    if structure.stiffness_model != "members" or not len(members):
        return np.zeros(len(members), dtype=bool)
    layout = body_layout(structure)
    ends = members.nodes
    p = structure.positions_m
    length = np.linalg.norm(p[ends[:, 1]] - p[ends[:, 0]], axis=1)
    rest = members.rest_length_m
    ok = (members.kind == _STRUT) & (layout.kind[ends] == PARTICLE).all(axis=1)
    ok &= np.abs(length - rest) <= FLEX_REST_RTOL * rest
    key = ends.min(axis=1) * structure.n_nodes + ends.max(axis=1)
    _, first, counts = np.unique(key[ok], return_inverse=True, return_counts=True)
    ok[np.flatnonzero(ok)[counts[first] > 1]] = False
    return ok


def _write_flexes(g: _Geometry, spec: mujoco.MjSpec, flex: np.ndarray) -> None:
    """The flex struts ``flex`` (m,) as one 1-D flex per distinct ``(k, c)`` (module docstring)."""
    members = g.structure.members
    j = np.flatnonzero(flex)
    if not j.size:
        return
    values, group = np.unique(
        np.column_stack([members.stiffness_N_m[j], members.damping_Ns_m[j]]), axis=0, return_inverse=True
    )
    by_group = np.argsort(group, kind="stable")
    starts = np.searchsorted(group[by_group], np.arange(len(values) + 1))
    for k, (stiffness, damping) in enumerate(values.tolist()):
        ends = members.nodes[j[by_group[starts[k] : starts[k + 1]]]]
        vertices, local = np.unique(ends, return_inverse=True)
        element = spec.add_flex()
        element.name = f"{_FLEX_PREFIX}{k}"
        element.dim = 1
        element.vertbody = [f"n{v}" for v in vertices.tolist()]
        element.vert = np.zeros(3 * vertices.size).tolist()
        element.elem = local.reshape(-1).tolist()
        element.edgestiffness = float(stiffness)
        element.edgedamping = float(damping)
        element.radius = g.width_m
        element.rgba = list(STRUT_RGBA)
        element.contype = 0
        element.conaffinity = 0
        element.selfcollide = mujoco.mjtFlexSelf.mjFLEXSELF_NONE


def _write_tendons(g: _Geometry, spec: mujoco.MjSpec, flex: np.ndarray) -> None:
    members = g.structure.members
    # a structure-level linear stiffness is a load: the tendons then carry no spring
    k = members.stiffness_N_m if g.structure.stiffness_model == "members" else np.zeros(len(members))
    j = np.flatnonzero((members.kind != _BEAM) & ~flex)
    rest = members.rest_length_m[j]
    columns = (
        j.tolist(),
        members.nodes[j].tolist(),
        k[j].tolist(),
        members.damping_Ns_m[j].tolist(),
        np.where(members.kind[j] == _CABLE, 0.0, rest).tolist(),  # the dead band's lower end
        rest.tolist(),
    )
    for index, ends, stiffness, damping, low, l0 in zip(*columns):
        add_spring_tendon(
            spec,
            index=index,
            ends=(ends[0], ends[1]),
            stiffness_N_m=stiffness,
            damping_Ns_m=damping,
            springlength_m=(low, l0),
            width_m=g.width_m,
        )


def _write_panels(g: _Geometry, spec: mujoco.MjSpec, inflate_m: float) -> None:
    """The rendering-only skin of the panels (module docstring)."""
    triangles = g.structure.panels.triangles()
    corners, local = np.unique(triangles, return_inverse=True)
    local = local.reshape(-1, 3)
    k = corners.size
    owner = g.layout.node_vertex[corners]
    bones, bone_of = np.unique(owner, return_inverse=True)
    skin = spec.add_skin()
    skin.name = "panels"
    skin.rgba = list(PANEL_RGBA)
    skin.inflate = inflate_m
    skin.vert = np.tile(g.structure.positions_m[corners], (2, 1)).ravel().tolist()
    skin.face = np.concatenate([local, local[:, ::-1] + k]).ravel().tolist()
    skin.bodyname = [g.body_name(int(b)) for b in bones]
    skin.bindpos = g.origin_m[bones].ravel().tolist()
    skin.bindquat = np.tile([1.0, 0.0, 0.0, 0.0], bones.size).tolist()
    by_bone = np.argsort(bone_of, kind="stable")
    groups = np.split(by_bone, np.cumsum(np.bincount(bone_of, minlength=bones.size))[:-1])
    skin.vertid = [np.concatenate([grp, grp + k]).tolist() for grp in groups]
    skin.vertweight = [[1.0] * (2 * grp.size) for grp in groups]


def build_structure_spec(
    structure: Structure,
    *,
    timestep_s: float,
    integrator: str,
    name: str | None = None,
    node_damping_1_s: float = 0.0,
    solver_tolerance: float | None = None,
    node_radius_m: float | None = None,
    member_width_m: float | None = None,
    extent_m: float | None = None,
    visual_geoms: bool = True,
    strut_elements: str = "auto",
) -> mujoco.MjSpec:
    """The ``MjSpec`` of ``structure`` (module docstring).

    Args:
      structure: the structure (its positions are the world frame at the reference).
      timestep_s: MuJoCo ``opt.timestep`` [s].
      integrator: one of :data:`~magsail_mj.mjcf.common.INTEGRATORS`.
      name: model name (default: the structure's name).
      node_damping_1_s: viscous damping of particles ``a = −c v`` [1/s] (particles only).
      solver_tolerance: MuJoCo ``opt.tolerance`` (``None``: MuJoCo's default).
      node_radius_m: radius of the node spheres (default 4 % of the median member rest length, or
        of the structure's extent without members); also the radius of a beam node's own sphere
        inertia.
      member_width_m: drawn tendon width (default 1.5 % of the same length).
      extent_m: the size the view and the light are set for (default: the largest side of the
        nodes' bounding box; a generator that knows its nominal size passes it).
      visual_geoms: draw beams as capsules and rigid parts as boxes (module docstring, "Drawn
        beams and rigid parts"; no effect on the dynamics).
      strut_elements: one of :data:`STRUT_ELEMENTS`: struts as tendons, as 1-D flex edges where
        they qualify, or (``"auto"``) flexes for large models under ``Euler``/``RK4`` (module
        docstring, "Flex struts").

    Raises:
      StructureError: the structure cannot be modelled (every finding, each naming the element).
      ValueError: a bad option (named).
    """
    if strut_elements not in STRUT_ELEMENTS:
        raise ValueError(f"strut_elements: must be one of {STRUT_ELEMENTS}, got {strut_elements!r}")
    masses = structure.lumped_masses()
    layout = body_layout(structure)
    _check(structure, layout, masses, float(node_damping_1_s))
    extent = _extent_m(structure.positions_m) if extent_m is None else float(extent_m)
    scale = float(np.median(structure.members.rest_length_m)) if structure.n_members else extent
    for label, value in (("node_radius_m", node_radius_m), ("member_width_m", member_width_m), ("extent_m", extent_m)):
        if value is not None and not (np.isfinite(value) and value > 0):
            raise ValueError(f"{label}: must be finite and > 0, got {value!r}")
    beams = np.flatnonzero(structure.members.kind == _BEAM)
    frames = np.zeros((structure.n_members, 3, 3))
    frames[beams] = beam_frames(structure, beams)
    parts = np.array([part.center_m for part in structure.rigid_parts], dtype=float).reshape(-1, 3)
    share = layout.closing_share(structure.n_nodes)
    g = _Geometry(
        structure=structure,
        layout=layout,
        origin_m=np.vstack([structure.positions_m, parts]),
        masses_kg=masses * share,
        rotary_kg_m2=node_rotary_inertia(structure) * share[:, None, None],
        frames=frames,
        radius_m=node_radius_m or 0.04 * scale,
        width_m=member_width_m or 0.015 * scale,
        node_damping_1_s=float(node_damping_1_s),
        visual_geoms=bool(visual_geoms),
    )
    spec = truss_base_spec(
        name=structure.name if name is None else name,
        timestep_s=timestep_s,
        integrator=integrator,
        solver_tolerance=solver_tolerance,
        extent_m=extent,
    )
    dofs = _write_bodies(g, spec)
    spec.memory = lattice_arena_bytes(int(dofs.sum())) + _constraint_arena_bytes(layout, dofs)
    _write_constraints(g, spec)
    flex = flex_struts(structure) if strut_elements != "tendons" else np.zeros(structure.n_members, dtype=bool)
    if strut_elements == "auto":
        tendon_dofs = float(np.count_nonzero(structure.members.kind != _BEAM)) * float(dofs.sum())
        if integrator not in _FLEX_AUTO_INTEGRATORS or tendon_dofs <= FLEX_AUTO_TENDON_DOFS:
            flex[:] = False
    _write_tendons(g, spec, flex)
    _write_flexes(g, spec, flex)
    if len(structure.panels):
        _write_panels(g, spec, inflate_m=0.25 * g.radius_m)
    return spec


@dataclass(frozen=True)
class StructureModelIndex:
    """Where a structure's nodes and members are in a compiled model (arrays built once).

    Attributes:
      node_body: (n,) body holding each node (a particle's or beam node's own body, or its part's).
      node_site: (n,) site of each node (tendons attach there; ``site_xpos`` is the node position).
      node_slide_qposadr, node_slide_dofadr: (n, 3) ``qpos``/``qvel`` addresses of the x, y, z
        world-axis slide joints of a node's own body (a particle, or a held beam root); −1 for a
        fixed component or a node without them.
      member_tendon: (m,) tendon of each strut or cable (−1 for beams and flex struts).
      member_flex_edge: (m,) flex edge of each flex strut (``flexedge_length`` index; −1 for the
        others).
      beam_qposadr, beam_dofadr: (m, 4) addresses of each beam's ``axial, twist, bend1, bend2``
        joints (−1 for struts and cables).
      part_body: (P,) body of each rigid part.
      particles_only: every node is a particle (positions follow from ``qpos`` without kinematics).
      center_of_mass_m: (3,) the structure's centre of mass, world frame at the reference [m].
    """

    node_body: np.ndarray
    node_site: np.ndarray
    node_slide_qposadr: np.ndarray
    node_slide_dofadr: np.ndarray
    member_tendon: np.ndarray
    member_flex_edge: np.ndarray
    beam_qposadr: np.ndarray
    beam_dofadr: np.ndarray
    part_body: np.ndarray
    particles_only: bool
    center_of_mass_m: np.ndarray

    @classmethod
    def from_model(cls, model: mujoco.MjModel, structure: Structure) -> StructureModelIndex:
        """The index of ``structure``'s elements in ``model`` (built by :func:`build_structure_spec`,
        possibly with further bodies added), found by name."""

        def ids(kind: mujoco.mjtObj, names: list[str]) -> np.ndarray:
            return np.array([mujoco.mj_name2id(model, kind, nm) for nm in names], dtype=np.int64).reshape(-1)

        n, members = structure.n_nodes, structure.members
        site = ids(mujoco.mjtObj.mjOBJ_SITE, [f"s{i}" for i in range(n)])
        if np.any(site < 0):
            raise ValueError(f"model: node sites missing (first: s{int(np.flatnonzero(site < 0)[0])})")
        slide = ids(mujoco.mjtObj.mjOBJ_JOINT, [f"n{i}_{a}" for i in range(n) for a in _AXES]).reshape(n, 3)
        beams = np.flatnonzero(members.kind == _BEAM)
        beam_joint = np.full((structure.n_members, 4), -1, dtype=np.int64)
        beam_joint[beams] = ids(mujoco.mjtObj.mjOBJ_JOINT, [f"m{j}_{s}" for j in beams for s in BEAM_JOINTS]).reshape(
            -1, 4
        )
        tendon = np.full(structure.n_members, -1, dtype=np.int64)
        others = np.flatnonzero(members.kind != _BEAM)
        tendon[others] = ids(mujoco.mjtObj.mjOBJ_TENDON, [f"t{j}" for j in others])
        edge = cls._flex_edges(model, structure, model.site_bodyid[site], others[tendon[others] < 0])
        part = ids(mujoco.mjtObj.mjOBJ_BODY, [part_body_name(p.name) for p in structure.rigid_parts])

        def address(table: np.ndarray, joints: np.ndarray) -> np.ndarray:
            return np.where(joints >= 0, table[np.maximum(joints, 0)], -1)

        return cls(
            node_body=model.site_bodyid[site].astype(np.int64),
            node_site=site,
            node_slide_qposadr=address(model.jnt_qposadr, slide),
            node_slide_dofadr=address(model.jnt_dofadr, slide),
            member_tendon=tendon,
            member_flex_edge=edge,
            beam_qposadr=address(model.jnt_qposadr, beam_joint),
            beam_dofadr=address(model.jnt_dofadr, beam_joint),
            part_body=part,
            particles_only=bool(beams.size == 0 and not structure.rigid_parts),
            center_of_mass_m=structure.mass_properties()[1],
        )

    @staticmethod
    def _flex_edges(
        model: mujoco.MjModel, structure: Structure, node_body: np.ndarray, members: np.ndarray
    ) -> np.ndarray:
        """(m,) the flex edge of each of ``members`` (struts without a tendon) in the flexes
        ``struts<g>``, by their end nodes' bodies; −1 elsewhere."""
        edge = np.full(structure.n_members, -1, dtype=np.int64)
        if not members.size:
            return edge
        flexes = [
            f
            for f in range(model.nflex)
            if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_FLEX, f).startswith(_FLEX_PREFIX)
        ]
        rows = [model.flex_edgeadr[f] + np.arange(model.flex_edgenum[f]) for f in flexes]
        rows = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
        flex_of_row = np.repeat(np.asarray(flexes, dtype=np.int64), [model.flex_edgenum[f] for f in flexes])
        vertex = model.flex_edge[rows] + model.flex_vertadr[flex_of_row][:, None]
        body = model.flex_vertbodyid[vertex]
        node_of_body = np.full(model.nbody, -1, dtype=np.int64)
        node_of_body[node_body] = np.arange(node_body.size)
        nodes = np.sort(node_of_body[body], axis=1)
        n = structure.n_nodes
        edge_key = nodes[:, 0] * n + nodes[:, 1]
        ends = np.sort(structure.members.nodes[members], axis=1)
        member_key = ends[:, 0] * n + ends[:, 1]
        order = np.argsort(edge_key, kind="stable")
        at = np.minimum(np.searchsorted(edge_key[order], member_key), max(order.size - 1, 0))
        found = order.size > 0 and np.all(edge_key[order][at] == member_key)
        if not found:
            missing = (
                int(members[0])
                if order.size == 0
                else int(members[np.flatnonzero(edge_key[order][at] != member_key)[0]])
            )
            raise ValueError(f"model: member {missing} has neither a tendon t{missing} nor a flex edge")
        edge[members] = rows[order[at]]
        return edge

    def node_positions(self, data: mujoco.MjData) -> np.ndarray:
        """(n, 3) world node positions of ``data`` (after ``mj_kinematics`` or ``mj_forward``)."""
        return data.site_xpos[self.node_site]

    def node_positions_from_qpos(self, model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
        """World node positions ``(…, n, 3)`` from ``qpos`` ``(…, nq)``: the reference position plus
        the slide coordinates for particles (vectorised), else MuJoCo's kinematics per state."""
        qpos = np.asarray(qpos, dtype=float)
        if qpos.shape[-1] != model.nq:
            raise ValueError(f"qpos: last axis must be nq = {model.nq}, got shape {qpos.shape}")
        if self.particles_only:
            ref = model.body_pos[self.node_body] + model.site_pos[self.node_site]
            moving = self.node_slide_qposadr >= 0
            shift = np.where(moving, qpos[..., np.maximum(self.node_slide_qposadr, 0)], 0.0)
            return ref + shift
        data = mujoco.MjData(model)
        flat = qpos.reshape(-1, model.nq)
        out = np.empty((flat.shape[0], self.node_site.size, 3))
        for k, q in enumerate(flat):
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            out[k] = data.site_xpos[self.node_site]
        return out.reshape(qpos.shape[:-1] + (self.node_site.size, 3))

    def member_lengths_m(self, data: mujoco.MjData, structure: Structure) -> np.ndarray:
        """(m,) distance between each member's end nodes in ``data`` [m] (after kinematics)."""
        p = self.node_positions(data)
        ends = structure.members.nodes
        return np.linalg.norm(p[ends[:, 1]] - p[ends[:, 0]], axis=1)
