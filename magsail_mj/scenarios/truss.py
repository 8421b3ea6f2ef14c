"""The flexible truss concept (``truss_magnetorquer``), spec truss-magnetorquer-array.md.

Importing this module registers the concept: its config schema
(:mod:`magsail_mj.scenarios.truss_config`, :class:`TrussConfig`) and its tasks, one class per
scenario kind (:mod:`magsail_mj.scenarios.truss_tasks`: ``dist_vs_central`` §6, ``cantilever``
§2.7, ``free``, ``detumble`` §9.3, ``slew`` §9.4–9.6). The model builder is
:mod:`magsail_mj.scenarios.truss_model`; metrics, orbital pieces and plots are
:mod:`~magsail_mj.scenarios.truss_metrics`, :mod:`~magsail_mj.scenarios.truss_orbital` and
:mod:`~magsail_mj.scenarios.truss_plots`.
"""

from __future__ import annotations

from magsail_mj.scenarios.truss_config import ORBITAL_SCENARIOS, TrussConfig, first_cantilever_omega
from magsail_mj.scenarios.truss_model import TrussModel, actuated_struts, make_cantilever_model, make_truss_model
from magsail_mj.scenarios.truss_tasks import TrussScenario, build_truss_scenario

__all__ = [
    "ORBITAL_SCENARIOS", "TrussConfig", "TrussScenario", "build_truss_scenario", "TrussModel",
    "make_truss_model", "make_cantilever_model", "actuated_struts", "first_cantilever_omega",
]
