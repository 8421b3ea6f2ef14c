"""Config schema of the ``structure`` concept: any structure file through validate, build and run.

A config names its structure under ``[structure]`` — a file (``file = "sail.toml"``: a structure
file, a gmsh mesh or any format meshio reads, or a Nastran deck, relative to the config file's
folder) or the structure format's own tables inline — and says what happens to it:

``scenario``
    ``free`` (no actuator: angular momentum and energy, libration in orbit), ``detumble`` (B-dot
    through magnetorquer rods along a member set, ``[actuators]``, and/or current loops along
    member sets, ``[loops]``) or ``slew`` (quaternion PD on the best-fit rigid attitude through
    them); the tasks are :mod:`magsail_mj.concepts.structure.tasks`.

The environment tables are the other concepts'; ``srp.enabled`` and ``drag.enabled`` put solar
pressure and drag on the structure's panels (refused for a structure without panels; each panel
has its own drag coefficient, so ``drag.drag_coefficient`` is refused).

Reading the structure is part of validation: every problem of the file is reported with its key
path (``structure.members[3].EA_N: must be > 0, got -1.0``; a file's problems after
``structure.file: <path>:``) and nothing is built or written. The validated config holds the
structure (:attr:`StructureTable.source`), its file resolved to an absolute path and the SHA-256
of every file read (``structure.sha256``, filled in when absent and checked when given), so the
run's identity changes when the structure file does. Keys in SI units (suffixes name them).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
from pydantic import Field, PrivateAttr, field_validator, model_validator

from magsail_mj.concepts import register_config
from magsail_mj.concepts.structure.circuits import LoopEdges, LoopError
from magsail_mj.concepts.structure.source import (
    INLINE_KEYS,
    collinear,
    file_kind,
    model_counts,
    read_source,
    with_rods,
)
from magsail_mj.config import (
    CONFIG_DIR,
    MJ_MINVAL,
    ConfigProblem,
    LatticeRenderConfig,
    SimConfig,
    StrictModel,
    derived_quantity,
)
from magsail_mj.environment.config import DragConfig, EnvironmentTables, environment_problems
from magsail_mj.resources import structure_model_bytes
from magsail_mj.structure.fileformat import StructureSource
from magsail_mj.structure.mesh import MemberProperties, PanelProperties
from magsail_mj.structure.mjcf import build_structure_spec
from magsail_mj.structure.model import Structure, StructureError
from magsail_mj.structure.stability import UNSTABLE_GROWTH, largest_stable_fraction, step_growth

__all__ = [
    "CONTROL_KINDS",
    "MemberGroupConfig",
    "PanelGroupConfig",
    "MeshImportConfig",
    "NastranImportConfig",
    "StructureTable",
    "RodsConfig",
    "LoopsConfig",
    "StructureControlConfig",
    "StructureInitialConfig",
    "StructureRenderConfig",
    "StructureTables",
    "StructureConfig",
]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

CONTROL_KINDS = {"detumble": "bdot", "slew": "quat_pd"}
"""The ``control.kind`` each actuated scenario takes."""
_QUAT_TOL = 1e-6


def _unit(q: Quat, key: str) -> Quat:
    if abs(math.hypot(*q) - 1.0) > _QUAT_TOL:
        norm = math.hypot(*q)
        raise ConfigProblem(key, f"must be a unit quaternion [w, x, y, z] (|q| within 1e-6 of 1), got norm {norm:.9g}")
    return q


# ----------------------------------------------------------------------------- [structure]


class MemberGroupConfig(StrictModel):
    """Properties of the members made from a mesh's line elements (a curve physical group, or
    ``[structure.mesh.members]`` for lines in no mapped group): ``kind``, axial rigidity ``EA_N``,
    bending ``EI_Nm2`` (one value, or section axes 1 and 2; beams), torsion ``GJ_Nm2`` (beams),
    axial dashpot, prestrain ``ε0`` (rest length ``l / (1 + ε0)``), ``strain_limit`` (absent: none),
    linear density and the section-axis-1 ``orientation`` (zeros: the builder chooses)."""

    kind: Literal["strut", "cable", "beam"] = "strut"
    EA_N: float = Field(gt=0)
    EI_Nm2: float | tuple[float, float] = 0.0
    GJ_Nm2: float = Field(default=0.0, ge=0)
    damping_Ns_m: float = Field(default=0.0, ge=0)
    prestrain: float = Field(default=0.0, gt=-1)
    strain_limit: float | None = Field(default=None, gt=0)
    linear_density_kg_m: float = Field(default=0.0, ge=0)
    orientation: Vec3 = (0.0, 0.0, 0.0)

    @field_validator("EI_Nm2")
    @classmethod
    def _bending(cls, value: float | tuple[float, float]) -> float | tuple[float, float]:
        if any(v < 0 for v in np.atleast_1d(value)):
            raise ValueError(f"must be >= 0 (one value or [axis 1, axis 2]), got {value!r}")
        return value

    def properties(self) -> MemberProperties:
        """The mesh reader's :class:`~magsail_mj.structure.mesh.MemberProperties`."""
        values = self.model_dump()
        values["strain_limit"] = math.inf if self.strain_limit is None else self.strain_limit
        return MemberProperties(**values)


class PanelGroupConfig(StrictModel):
    """Properties of the panels made from a mesh's triangles and quads (a surface physical group,
    or ``[structure.mesh.panels]``): areal density, ``reflectivity`` (specular, diffuse, absorbed
    fractions summing to 1) and free-molecular drag coefficient."""

    reflectivity: Vec3
    areal_density_kg_m2: float = Field(default=0.0, ge=0)
    drag_coefficient: float = Field(default=2.2, ge=0)

    def properties(self) -> PanelProperties:
        """The mesh reader's :class:`~magsail_mj.structure.mesh.PanelProperties`."""
        return PanelProperties(**self.model_dump())


class MeshImportConfig(StrictModel):
    """``[structure.mesh]``: how a mesh file becomes a structure
    (:func:`magsail_mj.structure.mesh.read_mesh`). ``groups``: physical group name → member
    properties (a curve group) or panel properties (a surface group); ``members`` / ``panels``:
    the properties of elements in no mapped group (absent: such elements are an error); ``skip``:
    element types left out (``["tetra"]``); ``merge_tolerance_m``: merge points closer than this;
    ``length_unit_m``: the file's length unit (0.001 for millimetres)."""

    groups: dict[str, MemberGroupConfig | PanelGroupConfig] = Field(default_factory=dict)
    members: MemberGroupConfig | None = None
    panels: PanelGroupConfig | None = None
    skip: list[str] = Field(default_factory=list)
    merge_tolerance_m: float | None = Field(default=None, gt=0)
    length_unit_m: float = Field(default=1.0, gt=0)

    def reader_options(self) -> dict[str, Any]:
        """Keyword arguments of :func:`~magsail_mj.structure.mesh.read_mesh`."""
        return {
            "groups": {name: group.properties() for name, group in self.groups.items()},
            "members": None if self.members is None else self.members.properties(),
            "panels": None if self.panels is None else self.panels.properties(),
            "skip": tuple(self.skip),
            "merge_tolerance_m": self.merge_tolerance_m,
            "length_unit_m": self.length_unit_m,
        }


class NastranImportConfig(StrictModel):
    """``[structure.nastran]``: ``skip_unsupported`` skips the cards the deck reader does not model
    (:func:`magsail_mj.structure.nastran.read_nastran`; otherwise they are an error)."""

    skip_unsupported: bool = False


class StructureTable(StrictModel):
    """``[structure]``: the structure — ``file`` (a structure file ``*.toml``, a Nastran deck
    ``*.bdf``/``*.dat``/``*.nas``, or a mesh meshio reads, ``*.msh`` …; relative to the config
    file's folder, stored resolved), or the structure format's tables inline (``nodes``,
    ``member_groups``, ``panels``, ``rigid_parts``, ``sets``, ``member_sets``, ``fixed``, ``name``,
    ``format``, ``version``: see the structure file page). ``mesh`` / ``nastran``: the importer's
    options. ``sha256``: the SHA-256 of every file read, by name; filled in by validation, and
    when given, a file whose digest differs is refused."""

    file: str | None = None
    mesh: MeshImportConfig | None = None
    nastran: NastranImportConfig | None = None
    sha256: dict[str, str] | None = None
    format: Any = None
    version: Any = None
    name: Any = None
    nodes: Any = None
    sets: Any = None
    member_sets: Any = None
    member_groups: Any = None
    panels: Any = None
    rigid_parts: Any = None
    fixed: Any = None

    _source: StructureSource | None = PrivateAttr(default=None)

    @field_validator("file")
    @classmethod
    def _resolved(cls, value: str | None) -> str | None:
        if value is None:
            return None
        if not value.strip():
            raise ValueError(f"must name a file, got {value!r}")
        path = Path(value)
        if not path.is_absolute():
            path = (CONFIG_DIR.get() or Path.cwd()) / path
        return os.path.normpath(path)

    @property
    def source(self) -> StructureSource:
        """The structure read at validation and the SHA-256 of its files."""
        if self._source is None:  # pragma: no cover - set by the validator of every instance
            raise ValueError("structure: not read (a config table built without validation)")
        return self._source

    @property
    def structure(self) -> Structure:
        """The checked structure (without the rods' mass, see :meth:`StructureConfig.structure_with_rods`)."""
        return self.source.structure

    def problem_lines(self, problems: list[str]) -> list[str]:
        """Key-path lines of the structure's problems found after reading it (by the model builder),
        relative to the config's top level: ``structure.file: <path>: <problem>`` for a file,
        ``structure.<problem>`` inline."""
        lines = [line.replace("; ", ", ") for line in problems]
        return [
            f"structure.file: {self.file}: {line}" if self.file is not None else f"structure.{line}" for line in lines
        ]

    def _inline(self) -> dict[str, Any]:
        return {key: getattr(self, key) for key in INLINE_KEYS if getattr(self, key) is not None}

    @model_validator(mode="after")
    def _read(self) -> StructureTable:
        inline = self._inline()
        if self.file is None and not inline:
            raise ConfigProblem("file", "give the structure: file = '<path>' or its tables (nodes, member_groups, …)")
        if self.file is not None and inline:
            raise ConfigProblem(
                "file", f"give the structure once: a file or inline tables, got both (inline keys {sorted(inline)})"
            )
        kind = None if self.file is None else file_kind(self.file)
        if self.mesh is not None and kind != "mesh":
            raise ConfigProblem("mesh", f"the mesh importer's options need a mesh file, got {self.file!r}")
        if self.nastran is not None and kind != "nastran":
            raise ConfigProblem("nastran", f"the deck reader's options need a Nastran deck, got {self.file!r}")
        base = Path(self.file).parent if self.file is not None else (CONFIG_DIR.get() or Path.cwd())
        try:
            source = read_source(
                file=self.file,
                inline=inline,
                base_dir=base,
                mesh_options=None if self.mesh is None else self.mesh.reader_options(),
                skip_unsupported=self.nastran is not None and self.nastran.skip_unsupported,
            )
        except StructureError as err:
            lines = [line.replace("; ", ", ") for line in err.problems]
            if self.file is not None:
                lines = [f"file: {line}" for line in lines]
            raise ValueError("; ".join(lines)) from None
        if self.sha256 is not None and self.sha256 != source.sha256:
            raise ConfigProblem(
                "sha256",
                f"the files read have the digests {source.sha256}, not the ones given ({self.sha256}); "
                "the structure changed since these were recorded (remove the key to accept it)",
            )
        self.__dict__["sha256"] = dict(source.sha256)
        self._source = source
        return self


# ----------------------------------------------------------------------------- actuators, control


class RodsConfig(StrictModel):
    """``[actuators]``: magnetorquer rods along the members of ``member_set``, one rod per member,
    each a dipole along its member's current axis, ``m_r = u_r m_max,r r̂_r`` with the commanded
    activation ``u_r ∈ [−1, 1]``. The largest dipole of a rod is ``kappa_Am2_kg`` [A m²/kg] times
    its mass ``rod_linear_density_kg_m · l0`` (give both), or ``dipole_max_Am2`` [A m²] per rod.
    ``rod_linear_density_kg_m`` [kg/m] is added to those members' linear density (the rods' mass,
    half lumped at each end)."""

    member_set: str = Field(min_length=1)
    rod_linear_density_kg_m: float = Field(default=0.0, ge=0)
    kappa_Am2_kg: float | None = Field(default=None, gt=0)
    dipole_max_Am2: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _one_dipole(self) -> RodsConfig:
        if (self.kappa_Am2_kg is None) == (self.dipole_max_Am2 is None):
            raise ConfigProblem(
                "kappa_Am2_kg", "give exactly one of kappa_Am2_kg and dipole_max_Am2", others=("dipole_max_Am2",)
            )
        if self.kappa_Am2_kg is not None and not self.rod_linear_density_kg_m > 0:
            raise ConfigProblem(
                "rod_linear_density_kg_m",
                f"kappa_Am2_kg sizes each rod's dipole by its mass: needs a rod mass per length > 0, "
                f"got {self.rod_linear_density_kg_m!r}",
                others=("kappa_Am2_kg",),
            )
        return self


class LoopsConfig(StrictModel):
    """``[loops]``: current loops along member sets, each set one closed loop (every node of the set
    ends exactly two of its members, and they are connected; the current runs along the set's first
    member from its first node to its second and on around). Loop ``L`` with current
    ``I_L ∈ [−I_max,L, I_max,L]`` has the dipole ``I_L a_L``, ``a_L = ½ Σ x_a × x_b`` over its
    directed members at the current node positions; each member feels the Lorentz force
    ``I_L (x_b − x_a) × B``, half at each end. ``I_max_A`` [A]: one limit for every loop or one per
    set. ``wire_linear_density_kg_m`` [kg/m] is added to each loop's members (the wire's mass,
    half lumped at each end; a member in two loops carries two wires)."""

    member_sets: list[str] = Field(min_length=1)
    I_max_A: float | list[float]
    wire_linear_density_kg_m: float = Field(default=0.0, ge=0)

    @field_validator("I_max_A")
    @classmethod
    def _limits(cls, value: float | list[float]) -> float | list[float]:
        values = np.atleast_1d(np.asarray(value, dtype=float))
        if values.size == 0 or not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError(f"must be a current > 0 A (one value, or one per member set), got {value!r}")
        return value

    @model_validator(mode="after")
    def _one_limit_per_set(self) -> LoopsConfig:
        names = self.member_sets
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ConfigProblem("member_sets", f"each set makes one loop: {twice[0]!r} is listed twice")
        if isinstance(self.I_max_A, list) and len(self.I_max_A) != len(names):
            raise ConfigProblem(
                "I_max_A",
                f"one limit for every loop or one per member set ({len(names)}: {names}), got {len(self.I_max_A)}",
            )
        return self

    def current_max_A(self) -> np.ndarray:
        """(L,) each loop's largest current [A]."""
        return np.broadcast_to(np.asarray(self.I_max_A, dtype=float), (len(self.member_sets),)).copy()


class StructureControlConfig(StrictModel):
    """``[control]`` of the actuated scenarios, sampled every ``period_s`` (absent: every step) and
    held in between.

    Attitude estimate: the least-squares rigid fit (Kabsch) of the nodes' positions to their
    reference positions gives the body → world rotation ``R``; the body rate is the backward
    difference of consecutive samples, ``ω = vee(log(R_prevᵀ R)) / δt`` (the initial rate at the
    first sample); the field in body axes is ``B_b = Rᵀ B``.

    ``kind = "bdot"`` (``detumble``): ``T_ref = k (ω × B_b) × B_b`` with ``k = k_bdot_Nms_T2``.
    ``kind = "quat_pd"`` (``slew``): ``T_ref = −P_q q_e,vec − P_ω ω`` (diagonal gains ``Pq_Nm``,
    ``Pw_Nms``), ``q_e = q_ref* ⊗ q`` towards ``q_ref_wxyz`` (body → world), plus the
    gravity-gradient compensation ``−3μ/r⁵ r_b × (I r_b)`` of the structure's inertia when
    ``gg_comp`` and the orbit is on.

    Allocation: the dipole ``m = B_b × T_ref / |B_b|²`` (whose torque ``m × B_b`` is ``T_ref``'s part
    across the field) is shared over the rods by the least-norm activations
    ``u = D⁺ m`` (``D`` the rods' largest dipoles along their reference axes); when an activation
    would pass 1 all are scaled down together (the torque keeps its direction: saturated).
    ``rate_threshold_rad_s``: the detumble counts as done when ``|ω|`` stays below it.
    """

    kind: Literal["bdot", "quat_pd"]
    period_s: float | None = Field(default=None, gt=0)
    k_bdot_Nms_T2: float = Field(default=1e12, ge=0)
    Pq_Nm: Vec3 = (1.0, 1.0, 1.0)
    Pw_Nms: Vec3 = (100.0, 100.0, 100.0)
    q_ref_wxyz: Quat | None = None
    gg_comp: bool = True
    rate_threshold_rad_s: float = Field(default=1e-3, gt=0)

    @model_validator(mode="after")
    def _gains(self) -> StructureControlConfig:
        for name in ("Pq_Nm", "Pw_Nms"):
            if any(not (g >= 0) for g in getattr(self, name)):
                raise ConfigProblem(name, f"gains must be >= 0, got {getattr(self, name)!r}")
        if self.q_ref_wxyz is not None:
            _unit(self.q_ref_wxyz, "q_ref_wxyz")
        return self


class StructureInitialConfig(StrictModel):
    """``[initial]``: the rigid initial state about the centre of mass ``c``: attitude ``q0_wxyz``
    (body → world, scalar first; node ``i`` at ``c + R (p_i − c)``) and body rate ``omega0_rad_s``
    [rad/s, body axes] (velocity ``R (ω × (p_i − c))``); undeformed and unstressed beyond the
    structure's prestrain."""

    q0_wxyz: Quat = (1.0, 0.0, 0.0, 0.0)
    omega0_rad_s: Vec3 = (0.0, 0.0, 0.0)

    @model_validator(mode="after")
    def _unit_quaternion(self) -> StructureInitialConfig:
        _unit(self.q0_wxyz, "q0_wxyz")
        return self


class StructureRenderConfig(LatticeRenderConfig):
    """``[render]``: video options (camera distance = ``distance_factor`` × the structure's extent)."""


# ----------------------------------------------------------------------------- the config


class StructureTables(StrictModel):
    """The concept's own keys and tables (:class:`StructureConfig` adds the environment tables)."""

    concept: Literal["structure"]
    scenario: Literal["free", "detumble", "slew"]
    description: str = ""
    sim: SimConfig
    structure: StructureTable
    actuators: RodsConfig | None = None
    loops: LoopsConfig | None = None
    control: StructureControlConfig | None = None
    initial: StructureInitialConfig = StructureInitialConfig()
    render: StructureRenderConfig = StructureRenderConfig()


@register_config("structure")
class StructureConfig(EnvironmentTables, StructureTables):
    """A ``structure`` config (``magsail_mj/concepts/structure/configs/*.toml``): the keys of
    :class:`StructureTables`, then the environment tables ``[orbit]`` … ``[gravity]`` (free space
    unless set; ``gravity.tidal`` acts on every node)."""

    #: sizes of the model validation compiled (:meth:`model_bytes`)
    _model_sizes: dict[str, int] = PrivateAttr(default_factory=dict)

    def rod_members(self) -> np.ndarray:
        """Indices of the members carrying rods (empty without ``[actuators]``)."""
        if self.actuators is None:
            return np.zeros(0, dtype=np.int64)
        return np.asarray(self.structure.structure.member_sets[self.actuators.member_set], dtype=np.int64)

    def structure_with_rods(self) -> Structure:
        """The structure with the rods' and the loops' wires' mass added to their members (the
        model's structure)."""
        density = 0.0 if self.actuators is None else self.actuators.rod_linear_density_kg_m
        structure = with_rods(self.structure.structure, self.rod_members(), rod_linear_density_kg_m=density)
        if self.loops is not None and self.loops.wire_linear_density_kg_m > 0:
            sets = structure.member_sets
            for name in self.loops.member_sets:
                structure = with_rods(
                    structure, sets[name], rod_linear_density_kg_m=self.loops.wire_linear_density_kg_m
                )
        return structure

    def loop_edges(self) -> LoopEdges | None:
        """The loops' directed edges and current limits (``None`` without ``[loops]``)."""
        if self.loops is None:
            return None
        sets = self.structure.structure.member_sets
        return LoopEdges.from_sets(
            self.structure.structure.members.nodes,
            {name: sets[name] for name in self.loops.member_sets},
            self.loops.current_max_A(),
        )

    def rod_dipole_max_Am2(self) -> np.ndarray:
        """(R,) largest dipole of each rod [A m²] (``κ ρ_rod l0``, or ``dipole_max_Am2``)."""
        a = self.actuators
        rods = self.rod_members()
        if a is None:
            return np.zeros(0)
        if a.dipole_max_Am2 is not None:
            return np.full(rods.size, a.dipole_max_Am2)
        l0 = self.structure.structure.members.rest_length_m[rods]
        return a.kappa_Am2_kg * a.rod_linear_density_kg_m * l0

    def model_counts(self) -> tuple[int, int, int]:
        """``(nv, nbody, ntendon)`` of the run's MuJoCo model (the memory estimate reads them)."""
        return model_counts(self.structure.structure)

    def model_bytes(self) -> float:
        """Memory of the run's MuJoCo model and data and of the build [bytes]
        (:func:`~magsail_mj.resources.structure_model_bytes`) from the sizes of the model validation
        compiled: ``nv``, bodies, tendons, the mass matrix's non-zeros ``nM`` (a chain of ``d`` beam
        dofs holds ``d (d + 1) / 2``) and the arena the builder set (the beam cycles' welds
        included)."""
        return structure_model_bytes(
            n_nodes=self.structure.structure.n_nodes,
            n_members=len(self.structure.structure.members.kind),
            **self._model_sizes,
        )

    @property
    def environment_needed(self) -> bool:
        """Whether the run samples an environment (an orbit, a field, solar pressure or drag)."""
        return self.orbit.enabled or self.field.model != "none" or self.srp.enabled or self.drag.enabled

    @model_validator(mode="after")
    def _tables_for_scenario(self) -> StructureConfig:
        sc = self.scenario
        if sc in CONTROL_KINDS:
            if self.actuators is None and self.loops is None:
                raise ValueError(
                    f"actuators: scenario {sc!r} needs an actuator: the [actuators] table (rods) or [loops]"
                )
            if self.control is None:
                raise ValueError(f"control: scenario {sc!r} needs the [control] table")
            if self.control.kind != CONTROL_KINDS[sc]:
                raise ConfigProblem(
                    "control.kind", f"scenario {sc!r} takes {CONTROL_KINDS[sc]!r}, got {self.control.kind!r}"
                )
            if self.field.model == "none":
                raise ConfigProblem(
                    "field.model", f"scenario {sc!r} drives magnetic actuators: needs a field, not 'none'"
                )
            if collinear(self.structure.structure.positions_m):
                raise ConfigProblem(
                    "structure", f"its nodes lie on one line: the attitude the {sc!r} controller fits is undefined"
                )
            if sc == "slew" and self.control.q_ref_wxyz is None:
                raise ConfigProblem("control.q_ref_wxyz", "scenario 'slew' needs the target attitude")
            if self.control.period_s is not None and self.control.period_s < self.sim.timestep_s * (1 - 1e-9):
                raise ConfigProblem(
                    "control.period_s",
                    f"must be >= sim.timestep_s = {self.sim.timestep_s} s, got {self.control.period_s}",
                )
        elif self.control is not None:
            raise ConfigProblem("control.kind", f"scenario {sc!r} has no controller: remove the [control] table")
        self._surfaces()
        if self.gravity.classical_torque:
            raise ConfigProblem(
                "gravity.classical_torque", "a flexible structure takes tidal gravity on every node (gravity.tidal)"
            )
        problems = environment_problems(self)
        if problems:
            raise ValueError("; ".join(problems))
        return self

    def _surfaces(self) -> None:
        """Solar pressure and drag act on the panels, each with its own drag coefficient."""
        if self.drag.drag_coefficient != DragConfig.model_fields["drag_coefficient"].default:
            raise ConfigProblem(
                "drag.drag_coefficient",
                "each panel carries its own drag_coefficient (the structure's panels table): remove the key, "
                f"got {self.drag.drag_coefficient!r}",
            )
        for key, on in (("srp.enabled", self.srp.enabled), ("drag.enabled", self.drag.enabled)):
            if on and len(self.structure.structure.panels) == 0:
                raise ConfigProblem(
                    key,
                    "solar pressure and drag act on the structure's panels, and it has none: "
                    "add panels or set it to false",
                )

    @model_validator(mode="after")
    def _rods(self) -> StructureConfig:
        a = self.actuators
        if a is None:
            return self
        sets = self.structure.structure.member_sets
        if a.member_set not in sets:
            raise ConfigProblem(
                "actuators.member_set", f"the structure has no member set {a.member_set!r} (it has {sorted(sets)})"
            )
        if len(sets[a.member_set]) == 0:
            raise ConfigProblem("actuators.member_set", f"member set {a.member_set!r} is empty")
        keys = {"actuators.rod_linear_density_kg_m": a.rod_linear_density_kg_m}
        total, _, inertia = self.structure_with_rods().mass_properties()
        derived_quantity("mass with the rods", total, keys=keys, minimum=MJ_MINVAL)
        derived_quantity("largest inertia with the rods", float(np.max(np.abs(inertia))), keys=keys)
        dipole = self.rod_dipole_max_Am2()
        key = "actuators.kappa_Am2_kg" if a.kappa_Am2_kg is not None else "actuators.dipole_max_Am2"
        derived_quantity(
            "rods' total dipole", float(np.sum(dipole)), keys={key: getattr(self.actuators, key.split(".")[1]), **keys}
        )
        return self

    @model_validator(mode="after")
    def _loops(self) -> StructureConfig:
        lc = self.loops
        if lc is None:
            return self
        structure = self.structure.structure
        sets = structure.member_sets
        for i, name in enumerate(lc.member_sets):
            if name not in sets:
                raise ConfigProblem(
                    f"loops.member_sets[{i}]", f"the structure has no member set {name!r} (it has {sorted(sets)})"
                )
        try:
            edges = self.loop_edges()
        except LoopError as err:
            i = next(k for k, name in enumerate(lc.member_sets) if f"member set {name!r}:" in str(err))
            raise ConfigProblem(f"loops.member_sets[{i}]", f"{err}") from None
        areas = edges.vector_areas(structure.positions_m)
        p = structure.positions_m
        for i, name in enumerate(lc.member_sets):
            k = edges.loop == i
            perimeter = float(np.linalg.norm(p[edges.dst[k]] - p[edges.src[k]], axis=1).sum())
            if not np.linalg.norm(areas[i]) > 1e-9 * perimeter**2:
                raise ConfigProblem(
                    f"loops.member_sets[{i}]",
                    f"loop {name!r} encloses no vector area at the reference ({areas[i].tolist()} m²): "
                    "it makes no dipole",
                )
        keys = {"loops.wire_linear_density_kg_m": lc.wire_linear_density_kg_m}
        total, _, inertia = self.structure_with_rods().mass_properties()
        derived_quantity("mass with the wires", total, keys=keys, minimum=MJ_MINVAL)
        derived_quantity("largest inertia with the wires", float(np.max(np.abs(inertia))), keys=keys)
        dipole = float(np.sum(lc.current_max_A() * np.linalg.norm(areas, axis=1)))
        derived_quantity("loops' total dipole", dipole, keys={"loops.I_max_A": lc.I_max_A})
        return self

    @model_validator(mode="after")
    def _modelled(self) -> StructureConfig:
        """The model is built and compiled as the run will (discarded): what the builder or MuJoCo
        refuses (two partially held nodes in one beam tree, a damped cable, a moving massless
        body, …) is refused here, naming the structure's element."""
        try:
            spec = build_structure_spec(
                self.structure_with_rods(),
                timestep_s=self.sim.timestep_s,
                integrator=self.sim.integrator,
                solver_tolerance=self.sim.solver_tolerance,
            )
            model = spec.compile()
        except StructureError as err:
            raise ValueError("; ".join(self.structure.problem_lines(err.problems))) from None
        except ValueError as err:  # MuJoCo's compiler
            where = f"file: {self.structure.file}: " if self.structure.file is not None else ""
            raise ConfigProblem("structure", f"{where}MuJoCo cannot compile the model: {err}") from None
        self._step_is_stable(model)
        self._model_sizes = {
            "nv": int(model.nv),
            "nbody": int(model.nbody),
            "ntendon": int(model.ntendon),
            "mass_nnz": int(model.nM),
            "arena_bytes": int(model.narena),
        }
        return self

    def _step_is_stable(self, model: mujoco.MjModel) -> None:
        """Refuse a time step at which the structure's stiffest modes grow on their own
        (:func:`~magsail_mj.structure.stability.step_growth` above
        :data:`~magsail_mj.structure.stability.UNSTABLE_GROWTH`): its run would blow up and read as
        a failed structure."""
        growth = step_growth(model)
        if growth <= UNSTABLE_GROWTH:
            return
        fraction = largest_stable_fraction(model)
        hint = (
            f"sim.timestep_s = {self.sim.timestep_s * fraction:.6g} s ({fraction:g} of it) is stable"
            if fraction is not None
            else "no step down to 1/64 of it is stable"
        )
        raise ConfigProblem(
            "sim.timestep_s",
            f"{self.sim.timestep_s} s is unstable for this structure with {self.sim.integrator}: a small "
            f"disturbance of its stiffest modes grows {growth:.3g} times per step (the step must resolve its "
            f"highest natural frequency); {hint}",
        )

    @model_validator(mode="after")
    def _initial_state(self) -> StructureConfig:
        structure = self.structure.structure
        fixed = np.asarray(structure.fixed_dofs, dtype=bool)
        moved = any(self.initial.omega0_rad_s) or tuple(self.initial.q0_wxyz) != (1.0, 0.0, 0.0, 0.0)
        if fixed.any() and (moved or self.orbit.enabled):
            node = int(np.flatnonzero(fixed.any(axis=1))[0])
            raise ConfigProblem(
                "structure.fixed",
                f"node {node} is held in place: a structure with fixed components runs in free space from "
                "rest at its reference attitude (orbit.enabled = false, initial.q0_wxyz and "
                "initial.omega0_rad_s left at their defaults)",
            )
        return self
