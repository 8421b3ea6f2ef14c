"""Writes the test meshes of tests/test_structure_mesh.py with the gmsh Python API (gmsh is not a
dependency of the package; run this by hand: ``python tests/data/meshes/make_meshes.py``).

- ``sail.msh`` (MSH 4.1) and ``sail_msh2.msh`` (MSH 2.2): a 1 m square membrane on four booms
  from the centre to the corners: curve group ``booms`` (the four booms, 2 elements each),
  curve group ``boom_0`` (the first boom again: elements in two groups), surface group
  ``membrane`` (the four quadrant triangles), point groups ``hub`` and ``tips``.
- ``quads.msh`` (MSH 4.1): a 1 m × 0.5 m plate of 4 × 2 quads (transfinite, recombined) with its
  edge curves in the group ``frame`` and the plate in ``plate``.
- ``tetra.msh`` (MSH 4.1): a 0.1 m cube meshed with tetrahedra (volume group ``solid``) and its
  12 edges in the group ``edges``.
"""

from pathlib import Path

import gmsh

HERE = Path(__file__).parent


def _sail(path: Path, version: float) -> None:
    gmsh.model.add("sail")
    geo = gmsh.model.geo
    hub = geo.addPoint(0, 0, 0, 0.5)
    tips = [geo.addPoint(0.5 * x, 0.5 * y, 0, 0.5) for x, y in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
    booms = [geo.addLine(hub, tip) for tip in tips]
    edges = [geo.addLine(tips[q], tips[(q + 1) % 4]) for q in range(4)]
    quadrants = [geo.addPlaneSurface([geo.addCurveLoop([booms[q], edges[q], -booms[(q + 1) % 4]])]) for q in range(4)]
    geo.synchronize()
    gmsh.model.addPhysicalGroup(1, booms, name="booms")
    gmsh.model.addPhysicalGroup(1, booms[:1], name="boom_0")
    gmsh.model.addPhysicalGroup(2, quadrants, name="membrane")
    gmsh.model.addPhysicalGroup(0, [hub], name="hub")
    gmsh.model.addPhysicalGroup(0, tips, name="tips")
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", version)
    gmsh.write(str(path))
    gmsh.model.remove()


def _quads(path: Path) -> None:
    gmsh.model.add("quads")
    geo = gmsh.model.geo
    corners = [geo.addPoint(x, y, 0) for x, y in ((0, 0), (1, 0), (1, 0.5), (0, 0.5))]
    sides = [geo.addLine(corners[q], corners[(q + 1) % 4]) for q in range(4)]
    plate = geo.addPlaneSurface([geo.addCurveLoop(sides)])
    for side, count in zip(sides, (5, 3, 5, 3)):
        geo.mesh.setTransfiniteCurve(side, count)
    geo.mesh.setTransfiniteSurface(plate)
    geo.mesh.setRecombine(2, plate)
    geo.synchronize()
    gmsh.model.addPhysicalGroup(1, sides, name="frame")
    gmsh.model.addPhysicalGroup(2, [plate], name="plate")
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.model.remove()


def _tetra(path: Path) -> None:
    gmsh.model.add("tetra")
    box = gmsh.model.occ.addBox(0, 0, 0, 0.1, 0.1, 0.1)
    gmsh.model.occ.synchronize()
    gmsh.model.mesh.setSize(gmsh.model.getEntities(0), 0.1)
    gmsh.model.addPhysicalGroup(3, [box], name="solid")
    gmsh.model.addPhysicalGroup(1, [tag for _, tag in gmsh.model.getEntities(1)], name="edges")
    gmsh.model.mesh.generate(3)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.model.remove()


if __name__ == "__main__":
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    _sail(HERE / "sail.msh", 4.1)
    _sail(HERE / "sail_msh2.msh", 2.2)
    _quads(HERE / "quads.msh")
    _tetra(HERE / "tetra.msh")
    gmsh.finalize()
