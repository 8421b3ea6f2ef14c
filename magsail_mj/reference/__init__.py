"""Reference integrators outside MuJoCo (the baselines the design measures against)."""

from magsail_mj.reference.numpy_rk4 import (
    SpringMassLattice,
    from_truss_scenario,
    load_forces_from,
    rk4_run,
    spring_forces,
)

__all__ = ["SpringMassLattice", "from_truss_scenario", "load_forces_from", "rk4_run", "spring_forces"]
