r"""The CNUSAIL-1 sail cubesat (concept ``cnusail``): the concept
package.

Paper: Yoo et al. 2016 (CNUSAIL-1: Yoo, Kim, Suk, Kim, IJASS 17(4) 2016). A rigid 3U bus
with a 2 m × 2 m sail (stowed or deployed mass properties) and three reaction-wheel rotors on
hinges (:mod:`magsail_mj.concepts.cnusail.mjcf`) rides the J2 reference orbit (Yoo et al. 2016, Table 1) in the
orbit-following world; gravity gradient, drag, SRP and residual-dipole torques
(:mod:`magsail_mj.concepts.cnusail.disturbances`) and the magnetorquer torque
(:mod:`magsail_mj.loads.actuators_cubesat`) enter through ``xfrc_applied``; the flight controller
(:mod:`magsail_mj.concepts.cnusail.modes`) drives the wheel motors through MuJoCo actuators.

Scenario ids (``magsail_mj/concepts/cnusail/configs/<id>.toml``) and what they run:

=====================  ===================================================================
``detumble_pre``       S1: B-dot, stowed, ω0 = [6, −7, 3] °/s, K = 3e4, 10 orbits
``detumble_post``      S2: B-dot, deployed, ω0 = [2, −7, 1] °/s, K = 5e4, 10 orbits
``nadir_pre``          S3: eigen-axis nadir slew, stowed, q_e(0) of the paper (146.5°), 1 orbit
``nadir_post``         S4: the same, deployed
``pd_vs_eigenaxis``    S5: 108° slew about the S3 axis, deployed; ``control.mode`` = eigen_axis
                       (S5b) or pd (S5a) — ``scripts/cnusail_pd_vs_eigenaxis.py`` runs both
``deorbit``            S6: nadir → deorbit attitude (90°), fixed gains, ν0 = 180°, 2 orbits
``deorbit_recalc``     S7: the same with the deorbit gain recalculation
``lifetime``           S8: orbit decay for the three attitude regimes (SciPy, no MuJoCo run)
=====================  ===================================================================

Parts: config schema :mod:`magsail_mj.concepts.cnusail.config`; model builder (config → MJCF,
environment, disturbances, controller) :mod:`magsail_mj.concepts.cnusail.model`; one task class per
``kind`` :mod:`magsail_mj.concepts.cnusail.tasks` (attitude) and
:mod:`magsail_mj.concepts.cnusail.lifetime` (lifetime); metrics and plots
:mod:`magsail_mj.concepts.cnusail.metrics`, :mod:`magsail_mj.concepts.cnusail.plots`.

Frames: world = ECI axes (origin on the reference orbit); body frame of Yoo et al. 2016 (ẑ_B = sail
normal); quaternions scalar-first, body → world. Config quaternions end in ``_wxyz``.

The package imports only its config schema; the registry (:mod:`magsail_mj.concepts`) imports
the ``tasks`` module, with the model, the plots and Matplotlib, when a scenario is built.
"""

from __future__ import annotations

from magsail_mj.concepts.cnusail.config import DEFAULT_BUS_CENTROID, TABLE2_INERTIA, CnusailConfig

__all__ = ["CnusailConfig", "TABLE2_INERTIA", "DEFAULT_BUS_CENTROID"]
