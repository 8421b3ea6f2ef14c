"""Structure generators: parametric plates, sails, hoops and masts, each returning a
:class:`~magsail_mj.structure.model.Structure` with named node and member sets, and the
cantilever calibration of a strut structure's axial rigidity to a plate bending stiffness."""

from magsail_mj.structure.generators.calibration import CantileverResult, calibrate_axial_rigidity, cantilever
from magsail_mj.structure.generators.clipped import circular_plate, hexagonal_plate
from magsail_mj.structure.generators.deployables import four_boom_sail, hoop, truss_mast
from magsail_mj.structure.generators.plates import octet_plate, offset_grid_plate, square_plate_lattice

__all__ = [
    "CantileverResult",
    "calibrate_axial_rigidity",
    "cantilever",
    "circular_plate",
    "four_boom_sail",
    "hexagonal_plate",
    "hoop",
    "octet_plate",
    "offset_grid_plate",
    "square_plate_lattice",
    "truss_mast",
]
