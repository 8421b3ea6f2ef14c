"""Model builder of the flexible truss concept: config → lattice → masses, springs → MjSpec.

Robb et al. 2022a: lattice, masses, stiffness, damping, and the torquer
struts). The lattice assembly itself is :mod:`magsail_mj.lattice.geometry`; the lattice with its
masses, springs and dashpots becomes a :class:`~magsail_mj.structure.model.Structure`
(:func:`~magsail_mj.structure.generators.plates.lattice_structure`), whose MjSpec is
:func:`magsail_mj.structure.mjcf.build_structure_spec` — the same model arrays as
:func:`magsail_mj.lattice.mjcf.build_truss_spec` of the lattice (tests/test_structure_truss.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from magsail_mj.lattice.geometry import Lattice, axial_rigidity_from_EI, make_lattice
from magsail_mj.lattice.properties import (
    clamped_nodes,
    node_masses,
    strut_damping,
    strut_stiffness,
)
from magsail_mj.structure.generators.plates import lattice_structure
from magsail_mj.structure.mjcf import build_structure_spec
from magsail_mj.structure.model import Structure
from magsail_mj.concepts.truss_magnetorquer.config import (
    ActuatorsConfig,
    StiffnessConfig,
    TrussConfig,
    first_cantilever_omega,
)
from magsail_mj.concepts.truss_magnetorquer.twist import diagonal_struts, twist_scaling

__all__ = [
    "TrussModel",
    "make_truss_model",
    "make_cantilever_model",
    "truss_structure",
    "actuated_struts",
    "axial_rigidities",
    "spring_constants",
]


@dataclass
class TrussModel:
    """Everything derived from the structural tables of a config.

    ``masses`` (n,) particle masses [kg]; ``k`` (S,) strut spring constants [N/m] (calibrated by
    ``calibration_factor``); ``gamma`` the strut dashpot constant [N s/m]; ``particle_mass_kg``
    M / n [kg]; ``total_kg`` M [kg]; ``spec`` the MjSpec; ``fixed_nodes`` the clamped nodes;
    ``twist_diagonal_ratio`` the face diagonals' spring constant per unit EA/l0 over the edges'
    (1 unless ``stiffness.twist = "plate"``); ``structure`` the lattice as a structure (what the
    MjSpec is built from).
    """

    lattice: Lattice
    masses: np.ndarray
    k: np.ndarray
    gamma: float
    calibration_factor: float
    particle_mass_kg: float
    total_kg: float
    spec: mujoco.MjSpec
    fixed_nodes: tuple[int, ...] = ()
    twist_diagonal_ratio: float = 1.0
    structure: Structure | None = None


def make_truss_model(cfg: TrussConfig, *, fixed_nodes=(), node_damping_1_s: float = 0.0) -> TrussModel:
    """Lattice, masses, spring constants, damping and the MjSpec of a config."""
    structure, lat, c, ratio = truss_structure(cfg, fixed_nodes=fixed_nodes)
    masses, k = structure.node_mass_kg, structure.members.stiffness_N_m
    gamma = float(structure.members.damping_Ns_m[0])
    m_p = _total_kg(cfg) / lat.n_nodes
    a = lat.cube_edge_m
    spec = build_structure_spec(
        structure,
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        name=f"truss_{cfg.scenario}",
        node_damping_1_s=node_damping_1_s,
        solver_tolerance=cfg.sim.solver_tolerance,
        node_radius_m=0.04 * a,  # the truss builder's sizes (the structure builder's default is
        member_width_m=0.015 * a,  # relative to the median member, the same length here)
        extent_m=lat.side_m,
    )
    return TrussModel(
        lattice=lat,
        masses=masses,
        k=k,
        gamma=gamma,
        calibration_factor=c,
        particle_mass_kg=m_p,
        total_kg=_total_kg(cfg),
        spec=spec,
        fixed_nodes=tuple(fixed_nodes),
        twist_diagonal_ratio=ratio,
        structure=structure,
    )


def _total_kg(cfg: TrussConfig) -> float:
    m = cfg.mass
    return m.total_kg if m.total_kg is not None else m.areal_density_kg_m2 * cfg.lattice.side_m**2


def truss_structure(cfg: TrussConfig, *, fixed_nodes=()) -> tuple[Structure, Lattice, float, float]:
    """The config's lattice as a :class:`Structure` — particle masses, strut axial rigidities
    (:func:`axial_rigidities`) and dashpots ``γ`` — with ``fixed_nodes`` held, and the lattice,
    the calibration factor ``c`` and the diagonal ratio ρ."""
    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    total = _total_kg(cfg)
    masses = node_masses(
        lat,
        total_kg=total,
        central_fraction=cfg.mass.central_fraction,
        point_masses=[(p.node, p.kg) for p in cfg.mass.point_masses],
    )
    EA, c, ratio = axial_rigidities(lat, cfg.stiffness)
    gamma = strut_damping(lat, EA / lat.rest_length, zeta=cfg.damping.zeta_strut, particle_mass_kg=total / lat.n_nodes)
    structure = lattice_structure(
        lat,
        masses_kg=masses,
        EA_N=EA,
        damping_Ns_m=gamma,
        fixed_nodes=tuple(int(i) for i in fixed_nodes),
        name=f"truss_{cfg.scenario}",
    )
    return structure, lat, c, ratio


def spring_constants(lat: Lattice, stiffness: StiffnessConfig) -> tuple[np.ndarray, float, float]:
    """Strut spring constants [N/m], the overall calibration factor ``c`` and the diagonal ratio ρ:
    ``k_s = EA_s / l0_s`` with the axial rigidities of :func:`axial_rigidities`."""
    EA, c, ratio = axial_rigidities(lat, stiffness)
    return EA / lat.rest_length, c, ratio


def axial_rigidities(lat: Lattice, stiffness: StiffnessConfig) -> tuple[np.ndarray, float, float]:
    """Strut axial rigidities ``EA_s`` [N], the overall calibration factor ``c`` and the diagonal
    ratio ρ.

    ``twist = "lattice"``: ``EA_s = c EA`` (Eq. 8, cantilever-calibrated). ``twist = "plate"``:
    ``EA_s = c EA · (ρ on face diagonals, 1 on edges)`` with ρ and c of
    :func:`~magsail_mj.concepts.truss_magnetorquer.twist.twist_scaling` (plate twist frequency,
    cantilever EI kept).
    """
    EA = axial_rigidity_from_EI(stiffness.EI_Nm2, nodes_per_side=lat.nodes_per_side, cube_edge_m=lat.cube_edge_m)
    if stiffness.twist == "lattice":
        _, c = strut_stiffness(lat, EI_Nm2=stiffness.EI_Nm2, calibration=stiffness.calibration)
        return np.full(lat.n_struts, c * EA), c, 1.0
    ts = twist_scaling(lat.units, lat.diagonals, float(stiffness.poisson_ratio))
    return ts.scale * EA * np.where(diagonal_struts(lat), ts.ratio, 1.0), ts.scale, ts.ratio


def actuated_struts(lat: Lattice, act: ActuatorsConfig, axis: str) -> np.ndarray:
    """Struts carrying torquers: a family of top-layer edges, or the central cube's.

    Torque about x1 comes from y1-struts and about y1 from x1-struts; about z1 both
    families act. ``central_pair="diagonal"`` takes the i0 top strut and the i0+1 bottom strut.
    """
    kinds = {"x1": ["y_edge"], "y1": ["x_edge"], "z1": ["x_edge", "y_edge"]}[axis]
    if act.placement == "distributed":
        return np.concatenate([lat.struts_of_kind(kd, layer=1) for kd in kinds])
    n = lat.units
    i0 = (n - 1) // 2
    out = []
    for kd in kinds:
        for s in lat.struts_of_kind(kd):
            a, b = lat.ijk[lat.struts[s]]
            lo = np.minimum(a, b)
            if kd == "y_edge" and lo[1] == i0 and lo[0] in (i0, i0 + 1):
                want_k = 1 if act.central_pair == "top" or lo[0] == i0 else 0
                if lo[2] == want_k:
                    out.append(s)
            if kd == "x_edge" and lo[0] == i0 and lo[1] in (i0, i0 + 1):
                want_k = 1 if act.central_pair == "top" or lo[1] == i0 else 0
                if lo[2] == want_k:
                    out.append(s)
    return np.array(sorted(out), dtype=int)


def make_cantilever_model(cfg: TrussConfig) -> TrussModel:
    """The model with its i = 0 edge clamped and node damping ``cantilever.settle_damping_1_s``
    [1/s] (default 2 ω₁, :func:`~magsail_mj.concepts.truss_magnetorquer.config.first_cantilever_omega`)."""
    lat = make_lattice(units=cfg.lattice.units, side_m=cfg.lattice.side_m, diagonals=cfg.lattice.diagonals)
    c = cfg.cantilever
    damping = c.settle_damping_1_s if c.settle_damping_1_s is not None else 2.0 * first_cantilever_omega(cfg)
    return make_truss_model(cfg, fixed_nodes=clamped_nodes(lat), node_damping_1_s=damping)
