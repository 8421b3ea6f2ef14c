"""The in-memory structure: nodes, members, panels, rigid parts and named sets (pure NumPy).

A :class:`Structure` is what every structure source becomes — a structure file (TOML with inline
tables or companion ``.npz``/``.csv`` arrays), a generator, a gmsh mesh or a Nastran deck — and
what the model builder, the loads, the metrics and the modal analysis read. Columns are arrays,
one row per element, so that loads and checks index them once and never loop in Python.

Frames and units: positions are in the **structure frame** (the body frame of the undeformed
structure; the builder places its origin at the centre of mass), SI throughout.

Member kinds (:data:`MEMBER_KINDS`):

``strut``
    axial spring–dashpot between the node centres, force ``−k (l − l0) − c l̇`` along the member,
    ``k = EA / l0``;
``cable``
    the same spring in tension only: no force while ``l ≤ l0`` (never pushes);
``beam``
    axial, bending (``EI`` about the member's two principal axes) and torsion (``GJ``); the nodes
    a beam touches carry rotational freedom.

Mass: each node has its lumped mass; a member with a linear density adds ``ρA l0 / 2`` to each of
its end nodes; a panel with an areal density adds ``ρ_A · area / (corners)`` to each corner; a
rigid part adds its own mass and inertia about its own centre of mass. :meth:`Structure.lumped_masses`
is the particle model's mass per node; :meth:`Structure.mass_properties` the whole structure's
mass, centre of mass and inertia.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "MEMBER_KINDS",
    "STIFFNESS_MODELS",
    "ModalDamping",
    "Members",
    "Panels",
    "RigidPart",
    "Structure",
    "StructureError",
]

#: Member kinds, in the order of their integer codes in :attr:`Members.kind`.
MEMBER_KINDS = ("strut", "cable", "beam")

#: How a structure's elastic forces are computed (:attr:`Structure.stiffness_model`):
#: ``"members"``, each member's own spring in the MuJoCo model (the exact, large-rotation law);
#: ``"corotational"``, the linear stiffness K of the struts assembled once at the reference,
#: co-rotated with the structure's best-fit rotation R̃, ``F = −R̃ K [R̃ᵀ(r − c) − (r₀ − c₀)]``
#: (Robb et al. 2022b, Eq. 12 with the rotation the equation needs); ``"paper_literal"``, Eq. 12
#: as printed, ``F = −K (r − R̃ r₀)`` with the unrotated K (valid for small rotations only). The
#: two linear forms are loads; the model's tendons then carry no spring.
STIFFNESS_MODELS = ("members", "corotational", "paper_literal")


class StructureError(ValueError):
    """A structure that cannot be modelled; ``problems`` lists every finding, each naming the
    element, the field and the value (``members[12].nodes: node 999 does not exist (800 nodes)``)."""

    def __init__(self, problems: list[str] | str):
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        super().__init__("\n".join(self.problems))


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class Members:
    """Member table, one row per member (``m`` rows).

    Attributes:
      nodes: (m, 2) end node indices.
      kind: (m,) index into :data:`MEMBER_KINDS`.
      EA_N: (m,) axial rigidity [N].
      EI_Nm2: (m, 2) bending rigidities about the section's axes 1 and 2 [N m²] (0 for struts and
        cables).
      GJ_Nm2: (m,) torsional rigidity [N m²] (0 for struts and cables).
      damping_Ns_m: (m,) axial dashpot ``c`` [N s/m].
      rest_length_m: (m,) unstrained length ``l0`` [m] (the node distance, or shortened by a
        prestrain ``ε0``: ``l0 = l / (1 + ε0)``).
      strain_limit: (m,) largest ``|l / l0 − 1|`` before the structure counts as failed (``inf``:
        none).
      linear_density_kg_m: (m,) mass per length lumped at the two ends [kg/m].
      orientation: (m, 3) a vector in the plane of section axis 1 (Nastran's ``v``; zeros: chosen
        by the builder, only beams use it).
    """

    nodes: np.ndarray
    kind: np.ndarray
    EA_N: np.ndarray
    EI_Nm2: np.ndarray
    GJ_Nm2: np.ndarray
    damping_Ns_m: np.ndarray
    rest_length_m: np.ndarray
    strain_limit: np.ndarray
    linear_density_kg_m: np.ndarray
    orientation: np.ndarray

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            _frozen(getattr(self, name))

    def __len__(self) -> int:
        return int(self.nodes.shape[0])

    def of_kind(self, name: str) -> np.ndarray:
        """Indices of the members of kind ``name``."""
        if name not in MEMBER_KINDS:
            raise ValueError(f"name: must be one of {MEMBER_KINDS}, got {name!r}")
        return np.flatnonzero(self.kind == MEMBER_KINDS.index(name))

    @property
    def stiffness_N_m(self) -> np.ndarray:
        """Axial spring constants ``k = EA / l0`` [N/m]."""
        return self.EA_N / self.rest_length_m

    @classmethod
    def build(
        cls,
        nodes: np.ndarray,
        *,
        positions_m: np.ndarray,
        kind: str | np.ndarray = "strut",
        EA_N: float | np.ndarray,
        EI_Nm2: float | np.ndarray = 0.0,
        GJ_Nm2: float | np.ndarray = 0.0,
        damping_Ns_m: float | np.ndarray = 0.0,
        rest_length_m: np.ndarray | None = None,
        prestrain: float | np.ndarray = 0.0,
        strain_limit: float | np.ndarray = np.inf,
        linear_density_kg_m: float | np.ndarray = 0.0,
        orientation: np.ndarray | None = None,
    ) -> Members:
        """A member table from end nodes and scalar or per-member properties; the rest length is
        the end nodes' distance at ``positions_m`` divided by ``1 + prestrain`` unless given."""
        ends = np.asarray(nodes, dtype=np.int64).reshape(-1, 2)
        m = ends.shape[0]

        def column(value, shape=(m,)) -> np.ndarray:
            return np.array(np.broadcast_to(np.asarray(value, dtype=float), shape), dtype=float)

        if isinstance(kind, str):
            if kind not in MEMBER_KINDS:
                raise ValueError(f"kind: must be one of {MEMBER_KINDS}, got {kind!r}")
            codes = np.full(m, MEMBER_KINDS.index(kind), dtype=np.int8)
        else:
            codes = np.array(np.broadcast_to(np.asarray(kind), (m,)), dtype=np.int8)
        if rest_length_m is None:
            p = np.asarray(positions_m, dtype=float)
            rest = np.linalg.norm(p[ends[:, 1]] - p[ends[:, 0]], axis=1) / (1.0 + column(prestrain))
        else:
            rest = column(rest_length_m)
        return cls(
            nodes=ends,
            kind=codes,
            EA_N=column(EA_N),
            EI_Nm2=column(np.asarray(EI_Nm2, dtype=float).reshape(-1, 1) if np.ndim(EI_Nm2) == 1 else EI_Nm2, (m, 2)),
            GJ_Nm2=column(GJ_Nm2),
            damping_Ns_m=column(damping_Ns_m),
            rest_length_m=rest,
            strain_limit=column(strain_limit),
            linear_density_kg_m=column(linear_density_kg_m),
            orientation=column(np.zeros(3) if orientation is None else orientation, (m, 3)),
        )

    @classmethod
    def concatenate(cls, tables: list[Members]) -> Members:
        """One table of the rows of ``tables`` in order."""
        return cls(**{name: np.concatenate([getattr(t, name) for t in tables]) for name in cls.__dataclass_fields__})


@dataclass(frozen=True)
class Panels:
    """Panel table (membranes, reflector facets), one row per panel (``p`` rows).

    Attributes:
      nodes: (p, 4) corner node indices, counter-clockwise about the panel's front normal; a
        triangle has ``-1`` as its fourth corner.
      areal_density_kg_m2: (p,) mass per area, lumped equally at the corners [kg/m²].
      reflectivity: (p, 3) fractions of incident sunlight reflected specularly, reflected
        diffusely and absorbed (each row sums to 1).
      drag_coefficient: (p,) free-molecular drag coefficient ``C_D`` of the panel.
    """

    nodes: np.ndarray
    areal_density_kg_m2: np.ndarray
    reflectivity: np.ndarray
    drag_coefficient: np.ndarray

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            _frozen(getattr(self, name))

    def __len__(self) -> int:
        return int(self.nodes.shape[0])

    @classmethod
    def empty(cls) -> Panels:
        return cls(
            nodes=np.zeros((0, 4), dtype=np.int64),
            areal_density_kg_m2=np.zeros(0),
            reflectivity=np.zeros((0, 3)),
            drag_coefficient=np.zeros(0),
        )

    def triangles(self) -> np.ndarray:
        """(t, 3) node indices: triangles as given, quads split along their 0–2 diagonal."""
        quad = self.nodes[:, 3] >= 0
        return np.concatenate([self.nodes[:, :3], self.nodes[quad][:, [0, 2, 3]]]).astype(np.int64)

    def areas_m2(self, positions_m: np.ndarray) -> np.ndarray:
        """(p,) panel areas at ``positions_m`` [m²] (quads as their two triangles)."""
        p = np.asarray(positions_m, dtype=float)
        n = self.nodes
        first = 0.5 * np.linalg.norm(np.cross(p[n[:, 1]] - p[n[:, 0]], p[n[:, 2]] - p[n[:, 0]]), axis=1)
        quad = n[:, 3] >= 0
        second = np.zeros(len(self))
        q = n[quad]
        second[quad] = 0.5 * np.linalg.norm(np.cross(p[q[:, 2]] - p[q[:, 0]], p[q[:, 3]] - p[q[:, 0]]), axis=1)
        return first + second


@dataclass(frozen=True)
class RigidPart:
    """A rigid part (a bus, a hub): its own mass and inertia, and the nodes it holds rigidly.

    Attributes:
      name: the part's name (unique in the structure).
      mass_kg: mass of the part itself (not counting its nodes' lumped masses).
      center_m: (3,) its centre of mass in the structure frame [m].
      inertia_kg_m2: (3, 3) its inertia about ``center_m``, structure axes [kg m²].
      nodes: indices of the nodes welded to the part.
    """

    name: str
    mass_kg: float
    center_m: np.ndarray
    inertia_kg_m2: np.ndarray
    nodes: np.ndarray

    def __post_init__(self) -> None:
        for name in ("center_m", "inertia_kg_m2", "nodes"):
            _frozen(getattr(self, name))


@dataclass(frozen=True)
class ModalDamping:
    """Structure-level Caughey (modal) damping, ``γ = M Φ diag(2 ξ_n ω_n) Φᵀ M`` over the free
    structure's modes (Robb et al. 2022b, Eqs. 13–15), beside or instead of member dashpots.

    Attributes:
      schedule: ``"paper_max"`` (``ξ_n = max(ξ_low, ω_n / ω_{n_low} · ξ_low)``-type schedule of the
        paper: :func:`magsail_mj.lattice.modes.damping_ratios`) or ``"capped_rayleigh"``.
      xi_low: damping ratio of the low modes.
      n_low: the number of low elastic modes at ``xi_low``.
      xi_cap: the largest damping ratio.
      frame: ``"body"`` (γ co-rotated with the structure) or ``"inertial"`` (assembled once in
        inertial axes).
      form: ``"dense"`` (the exact matrix) or ``"polynomial"`` (a matrix polynomial within
        ``rtol`` of the schedule above the low modes).
      rtol: relative tolerance of the polynomial form.
    """

    schedule: str = "paper_max"
    xi_low: float = 0.01
    n_low: int = 100
    xi_cap: float = 10.0
    frame: str = "body"
    form: str = "dense"
    rtol: float = 0.02


@dataclass(frozen=True)
class Structure:
    """A spacecraft structure.

    Attributes:
      name: the structure's name.
      positions_m: (n, 3) undeformed node positions, structure frame [m].
      node_mass_kg: (n,) point masses at the nodes, not counting member, panel or part mass [kg].
      members: the member table.
      panels: the panel table.
      rigid_parts: the rigid parts.
      node_sets: named node index sets (boundary conditions, metrics, sensors).
      member_sets: named member index sets (actuator placement: rods, current-carrying members).
      fixed_dofs: (n, 6) constrained components of each node (x, y, z translations, then
        rotations about x, y, z): a constrained component is held at its reference value.
      stiffness_model: how the elastic forces are computed (:data:`STIFFNESS_MODELS`).
      modal_damping: structure-level modal damping, or ``None``.
    """

    name: str
    positions_m: np.ndarray
    node_mass_kg: np.ndarray
    members: Members
    panels: Panels = field(default_factory=Panels.empty)
    rigid_parts: tuple[RigidPart, ...] = ()
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    member_sets: dict[str, np.ndarray] = field(default_factory=dict)
    fixed_dofs: np.ndarray | None = None
    stiffness_model: str = "members"
    modal_damping: ModalDamping | None = None

    def __post_init__(self) -> None:
        if self.stiffness_model not in STIFFNESS_MODELS:
            raise ValueError(f"stiffness_model: must be one of {STIFFNESS_MODELS}, got {self.stiffness_model!r}")
        if self.fixed_dofs is None:
            object.__setattr__(self, "fixed_dofs", np.zeros((self.positions_m.shape[0], 6), dtype=bool))
        for name in ("positions_m", "node_mass_kg", "fixed_dofs"):
            _frozen(getattr(self, name))
        for sets in (self.node_sets, self.member_sets):
            for values in sets.values():
                _frozen(values)

    @property
    def n_nodes(self) -> int:
        return int(self.positions_m.shape[0])

    @property
    def n_members(self) -> int:
        return len(self.members)

    def lumped_masses(self) -> np.ndarray:
        """(n,) mass of each node's particle [kg]: its point mass, half of every member's mass at
        each end, an equal share of every panel's mass at each corner (rigid parts excluded)."""
        mass = np.array(self.node_mass_kg, dtype=float)
        members = self.members
        half = 0.5 * members.linear_density_kg_m * members.rest_length_m
        np.add.at(mass, members.nodes[:, 0], half)
        np.add.at(mass, members.nodes[:, 1], half)
        panels = self.panels
        if len(panels):
            corners = np.where(panels.nodes[:, 3] >= 0, 4, 3)
            share = panels.areal_density_kg_m2 * panels.areas_m2(self.positions_m) / corners
            for c in range(4):
                real = panels.nodes[:, c] >= 0
                np.add.at(mass, panels.nodes[real, c], share[real])
        return mass

    def mass_properties(self) -> tuple[float, np.ndarray, np.ndarray]:
        """Total mass [kg], centre of mass (3,) [m] and inertia (3, 3) about it [kg m²], structure
        axes: the lumped particles plus the rigid parts (parallel-axis theorem)."""
        m = self.lumped_masses()
        p = self.positions_m
        total = float(m.sum()) + sum(part.mass_kg for part in self.rigid_parts)
        moment = m @ p + sum((part.mass_kg * part.center_m for part in self.rigid_parts), np.zeros(3))
        com = moment / total
        r = p - com
        inertia = np.einsum("i,ij,ik->jk", m, r, r)
        inertia = np.trace(inertia) * np.eye(3) - inertia
        for part in self.rigid_parts:
            d = part.center_m - com
            inertia = inertia + part.inertia_kg_m2 + part.mass_kg * (d @ d * np.eye(3) - np.outer(d, d))
        return total, com, inertia
