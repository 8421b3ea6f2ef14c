"""The ``structure`` concept: any structure file (a structure file, a gmsh mesh, a Nastran deck or
the structure format's tables inline) through validate, build and run, with no new Python.

The concept registers its config schema (:mod:`magsail_mj.concepts.structure.config`,
:class:`StructureConfig`) and its tasks, one class per scenario kind
(:mod:`magsail_mj.concepts.structure.tasks`: ``free``, ``detumble``, ``slew``). The model is
:mod:`~magsail_mj.concepts.structure.model` (the MuJoCo model of
:func:`magsail_mj.structure.mjcf.build_structure_spec`, node kinematics and the initial state), the
loads :mod:`~magsail_mj.concepts.structure.loads` (tidal gravity on every node, solar pressure and
drag on the panels, magnetorquer rods on a member set, current loops along member sets,
:mod:`~magsail_mj.concepts.structure.circuits`), the controller
:mod:`~magsail_mj.concepts.structure.control`, the metrics and plots
:mod:`~magsail_mj.concepts.structure.metrics` and :mod:`~magsail_mj.concepts.structure.plots`.

The package imports only its config schema; the registry (:mod:`magsail_mj.concepts`) imports
the ``tasks`` module, with MuJoCo and Matplotlib, when a scenario is built.
"""

from __future__ import annotations

from magsail_mj.concepts.structure.config import StructureConfig

__all__ = ["StructureConfig"]
