"""Current loops built into the flexible truss (``current_loops``), Robb et al. 2022b.

The concept registers its config schema
(:mod:`magsail_mj.concepts.current_loops.config`, :class:`CurrentLoopsConfig`) and its tasks, one
class per scenario kind (:mod:`magsail_mj.concepts.current_loops.tasks`: ``sweep``, ``slew``,
``slew_rigid``). The model builder is :mod:`magsail_mj.concepts.current_loops.model`;
probes and metrics :mod:`~magsail_mj.concepts.current_loops.metrics`, plots
:mod:`~magsail_mj.concepts.current_loops.plots`.

The lattice, masses and tendon springs are those of the truss concept (uniform particle
masses, ``EA_c = 2 EI / ((N+1) w²)``, ``calibration = "formula"`` by default). Elastic forces
are MuJoCo spring tendons (no tendon damping); Lorentz forces (Robb et al. 2022b, Eqs. 16–17),
modal damping (Robb et al. 2022b, Eq. 15) and tidal gravity are loads written into ``xfrc_applied``.

The package imports only its config schema; the registry (:mod:`magsail_mj.concepts`) imports
the ``tasks`` module, with the model, the plots and Matplotlib, when a scenario is built.
"""

from __future__ import annotations

from magsail_mj.concepts.current_loops.config import CurrentLoopsConfig, loop_currents
from magsail_mj.geometry.current_loops import CIRCUIT_NAMES

__all__ = ["CIRCUIT_NAMES", "CurrentLoopsConfig", "loop_currents"]
