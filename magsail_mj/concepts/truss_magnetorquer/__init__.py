"""The flexible truss concept (``truss_magnetorquer``), Robb et al. 2022a.

The concept registers its config schema
(:mod:`magsail_mj.concepts.truss_magnetorquer.config`, :class:`TrussConfig`) and its tasks, one class per
scenario kind (:mod:`magsail_mj.concepts.truss_magnetorquer.tasks`: ``dist_vs_central``, ``cantilever``,
``free``, ``detumble``, ``slew``). The model builder is
:mod:`magsail_mj.concepts.truss_magnetorquer.model`; metrics, orbital pieces and plots are
:mod:`~magsail_mj.concepts.truss_magnetorquer.metrics`, :mod:`~magsail_mj.concepts.truss_magnetorquer.orbital` and
:mod:`~magsail_mj.concepts.truss_magnetorquer.plots`.

The package imports only its config schema; the registry (:mod:`magsail_mj.concepts`) imports
the ``tasks`` module, with the model, the plots and Matplotlib, when a scenario is built.
"""

from __future__ import annotations

from magsail_mj.concepts.truss_magnetorquer.config import ORBITAL_SCENARIOS, TrussConfig, first_cantilever_omega

__all__ = ["ORBITAL_SCENARIOS", "TrussConfig", "first_cantilever_omega"]
