"""The flexible truss concept (``truss_magnetorquer``), Robb et al. 2022a.

Importing this module registers the concept: its config schema
(:mod:`magsail_mj.concepts.truss_magnetorquer.config`, :class:`TrussConfig`) and its tasks, one class per
scenario kind (:mod:`magsail_mj.concepts.truss_magnetorquer.tasks`: ``dist_vs_central``, ``cantilever``,
``free``, ``detumble``, ``slew``). The model builder is
:mod:`magsail_mj.concepts.truss_magnetorquer.model`; metrics, orbital pieces and plots are
:mod:`~magsail_mj.concepts.truss_magnetorquer.metrics`, :mod:`~magsail_mj.concepts.truss_magnetorquer.orbital` and
:mod:`~magsail_mj.concepts.truss_magnetorquer.plots`.
"""

from __future__ import annotations

from magsail_mj.concepts.truss_magnetorquer.config import ORBITAL_SCENARIOS, TrussConfig, first_cantilever_omega
from magsail_mj.concepts.truss_magnetorquer.model import (
    TrussModel,
    actuated_struts,
    make_cantilever_model,
    make_truss_model,
)
from magsail_mj.concepts.truss_magnetorquer.tasks import TrussScenario, build_truss_scenario

__all__ = [
    "ORBITAL_SCENARIOS",
    "TrussConfig",
    "TrussScenario",
    "build_truss_scenario",
    "TrussModel",
    "make_truss_model",
    "make_cantilever_model",
    "actuated_struts",
    "first_cantilever_omega",
]
