"""Write the structure files of the ``structure`` concept's shipped configs.

The configs ``magsail_mj/concepts/structure/configs/*.toml`` name these files
(``configs/structures/*.toml``), written here with
:func:`magsail_mj.structure.fileformat.write_structure` from the generators so that they are
reproducible:

``sail_100m.toml``
    A 100 m square solar sail (:func:`~magsail_mj.structure.generators.four_boom_sail`): four
    70.7 m booms of 4 beam members each from a 20 kg hub (a rigid part), EI = 8 000 N m² and
    GJ = 800 N m² (a CFRP tube of about 5 cm radius), 0.1 kg/m; the membrane, 5 g/m², as 64
    triangular panels whose edges are a net of 88 cables (EA = 1 000 N), a slack membrane's low
    in-plane stiffness rather than a taut film's. The net is form-found (the generator's
    ``edge_sag_ratio``, force density method): interior force density q_i = EA ε0 / a =
    5.66e-3 N/m (ε0 = 1e-4 over a = 17.7 m, a boom segment: 0.076-0.143 N in the found net), the
    free edges scalloped inward to a sag of a tenth of the side (10 m), which takes
    q_e = 1.48e-2 N/m (0.37-0.39 N in the rim cables); the membrane's area is then 7 480 m²
    (37.4 kg). The sag sets the rim's tension (the less sag, the more tension), and with it the
    booms' compression: 0.61-1.17 N at the prestress equilibrium, under a third of their buckling
    load as cantilevers from the hub, π² EI / (4 L²) = 3.9 N (a 5 m sag nearly triples the rim's
    tension, to 1.08 N, and takes them to 2.0 N; 2.5 m: 2.5 N and 3.7 N). The booms' axial
    rigidity is lowered to EA = 3e4 N (a tube's is about 6e6 N) so that the axial modes, which take
    no part in the attitude motion, stay below RK4's limit at δt = 0.05 s (ω_max δt < 2.8).
``octet_75m.toml``
    Robb et al. 2022a's 75 m plate read as the octahedral–tetrahedral truss
    (:func:`~magsail_mj.structure.generators.octet_plate`): 19 cubes of 3.95 m per side (the
    shipped lattice's), even-parity nodes and face diagonals with rim chords, EA calibrated to
    EI = 1e3 N m² by the cantilever rule, 100 kg spread over the nodes (the rods' 100 kg come from
    the config's ``actuators.rod_linear_density_kg_m``: 200 kg in all), strut damping ζ = 0.1.
``offset_grid_75m.toml``
    The same plate as the square-on-square offset double-layer grid
    (:func:`~magsail_mj.structure.generators.offset_grid_plate`): 14 cells of 5.36 m (close to
    the octet's 5.58 m chords), depth a/√2, corner bracing, the same calibration, mass and damping.
``reflector_100m.toml``
    A 100 m circular reflector (:func:`~magsail_mj.structure.generators.circular_plate`): the
    two-layer cubic lattice clipped to the disc by whole cubes, 19 cubes of 5.26 m across, EA set
    so that the lattice's homogenised plate rigidity is D11 = 100 N m
    (:func:`~magsail_mj.structure.plate_theory.cubic_lattice_rigidity`; EI = D d = 1e4 N m² over
    the 100 m, ten times the 75 m plates'), 150 kg of truss over the nodes, strut damping ζ = 0.1;
    a reflecting membrane on the top layer, one quad panel a cube (10 g/m², specular 0.85, diffuse
    0.05, absorbed 0.10). Its member sets ``rim_top`` and ``rim_bottom`` (the generator's) carry
    the current loops of ``reflector_loops_slew.toml``.

Usage::

    python scripts/make_structure_configs.py           # (re)write the structure files
    python scripts/make_structure_configs.py --check   # exit 1 if a committed file differs
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from magsail_mj.structure.fileformat import write_structure
from magsail_mj.structure.generators import circular_plate, four_boom_sail, octet_plate, offset_grid_plate
from magsail_mj.structure.model import Panels, Structure
from magsail_mj.structure.plate_theory import cubic_lattice_rigidity

OUT = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "structure" / "configs" / "structures"

#: the sail's membrane cable net: EA [N], prestrain (the interior cables' force density
#: q_i = EA ε0 / a, a = 17.7 m the boom segment) and the rim's sag as a fraction of the side
MEMBRANE_EA_N = 1.0e3
MEMBRANE_PRESTRAIN = 1.0e-4
EDGE_SAG_RATIO = 0.1


def sail() -> Structure:
    """The 100 m four-boom sail (module docstring)."""
    return four_boom_sail(
        side_m=100.0,
        n_segments=4,
        boom_EA_N=3.0e4,
        boom_EI_Nm2=8.0e3,
        boom_GJ_Nm2=8.0e2,
        boom_linear_density_kg_m=0.1,
        membrane_areal_density_kg_m2=0.005,
        reflectivity=(0.88, 0.03, 0.09),
        hub_mass_kg=20.0,
        hub_inertia_kg_m2=(1.5, 1.5, 2.5),
        net_EA_N=MEMBRANE_EA_N,
        net_prestrain=MEMBRANE_PRESTRAIN,
        edge_sag_ratio=EDGE_SAG_RATIO,
        name="sail_100m",
    )


def octet() -> Structure:
    """The 75 m octet plate (module docstring)."""
    return octet_plate(
        units=19, side_m=75.0, bracing="rim", EI_Nm2=1.0e3, total_mass_kg=100.0, zeta_strut=0.1, name="octet_75m"
    )


def offset_grid() -> Structure:
    """The 75 m offset double-layer grid (module docstring)."""
    return offset_grid_plate(
        cells=14,
        side_m=75.0,
        bracing="corners",
        EI_Nm2=1.0e3,
        total_mass_kg=100.0,
        zeta_strut=0.1,
        name="offset_grid_75m",
    )


#: the reflector: diameter [m], cubes across, plate rigidity D11 [N m], truss mass [kg], membrane
REFLECTOR_DIAMETER_M = 100.0
REFLECTOR_UNITS = 19
REFLECTOR_D11_NM = 100.0
REFLECTOR_TRUSS_KG = 150.0
REFLECTOR_MEMBRANE_KG_M2 = 0.01
REFLECTOR_OPTICS = (0.85, 0.05, 0.10)


def top_membrane(
    structure: Structure, *, areal_density_kg_m2: float, reflectivity: tuple[float, float, float]
) -> Structure:
    """``structure`` (a clipped two-layer cubic lattice) with one quad panel on the top face of
    every cube, corners counter-clockwise about +z (normal +z). A cube is found by its top-layer
    face diagonal (one a cube, both bracings)."""
    p = structure.positions_m
    top = p[:, 2] > p[:, 2].min() + 0.5 * np.ptp(p[:, 2])
    ends = structure.members.nodes
    d = p[ends[:, 1]] - p[ends[:, 0]]
    diagonal = top[ends[:, 0]] & top[ends[:, 1]] & (np.abs(d[:, 0]) > 0) & (np.abs(d[:, 1]) > 0)
    a = float(np.min(np.abs(d[diagonal, 0])))
    ij = np.rint((p[:, :2] - p[:, :2].min(axis=0)) / a).astype(np.int64)
    node_at = {(int(i), int(j)): int(n) for n, (i, j) in zip(np.flatnonzero(top), ij[top])}
    corner = np.minimum(ij[ends[diagonal, 0]], ij[ends[diagonal, 1]])
    quads = np.array([[node_at[(i + di, j + dj)] for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1))] for i, j in corner])
    count = quads.shape[0]
    panels = Panels(
        nodes=quads,
        areal_density_kg_m2=np.full(count, areal_density_kg_m2),
        reflectivity=np.tile(np.asarray(reflectivity, dtype=float), (count, 1)),
        drag_coefficient=np.full(count, 2.2),
    )
    return replace(structure, panels=panels)


def reflector() -> Structure:
    """The 100 m circular reflector (module docstring)."""
    a = REFLECTOR_DIAMETER_M / REFLECTOR_UNITS
    EA_N = REFLECTOR_D11_NM / cubic_lattice_rigidity(EA_N=1.0, cube_edge_m=a).D11_Nm
    plate = circular_plate(
        diameter_m=REFLECTOR_DIAMETER_M,
        units_across=REFLECTOR_UNITS,
        EA_N=EA_N,
        total_mass_kg=REFLECTOR_TRUSS_KG,
        zeta_strut=0.1,
        name="reflector_100m",
    )
    return top_membrane(plate, areal_density_kg_m2=REFLECTOR_MEMBRANE_KG_M2, reflectivity=REFLECTOR_OPTICS)


STRUCTURES = {
    "sail_100m.toml": sail,
    "octet_75m.toml": octet,
    "offset_grid_75m.toml": offset_grid,
    "reflector_100m.toml": reflector,
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare, write nothing")
    args = ap.parse_args(argv)
    stale = []
    for name, make in STRUCTURES.items():
        if args.check:
            with tempfile.TemporaryDirectory() as tmp:
                fresh = write_structure(make(), Path(tmp) / name)[0].read_text(encoding="utf-8")
            committed = OUT / name
            if not committed.is_file() or committed.read_text(encoding="utf-8") != fresh:
                stale.append(name)
            continue
        OUT.mkdir(parents=True, exist_ok=True)
        for path in write_structure(make(), OUT / name):
            print(path)
    if stale:
        print(f"stale structure files (run python scripts/make_structure_configs.py): {stale}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
