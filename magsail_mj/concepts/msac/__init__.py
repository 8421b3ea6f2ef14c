r"""The MSAC concept (``msac``): the concept package.

Vedant & Allison 2019. A bus turns itself with no wheels and no external torque by bending its two
point-symmetric wings one way while they are extended and back while they are contracted. Scenario ids:

* ``lumped`` — analytic only: Eqs. (6)–(7) (with the sign correction) and the exact planar
  model for the configured geometry; no MuJoCo steps.
* ``multibody`` — the MuJoCo model driven along the cycle (``paper_1khz``,
  ``paper_1khz_stroke10``, ``slow_1hz``, ``lumped_limit``, ``mirror_wings`` …).
* ``sweep`` — a base config plus a ``[sweep]`` table: the listed keys are set to each point's
  values and the multibody run and the references are evaluated per point (F6, F7).

Parts: config schema :mod:`magsail_mj.concepts.msac.config`; model builder (config → MjSpec,
cycle, planar model, analytic references) :mod:`magsail_mj.concepts.msac.model`; one task class
per scenario kind :mod:`magsail_mj.concepts.msac.tasks`; the runner
:mod:`magsail_mj.concepts.msac.runner`; plots :mod:`magsail_mj.concepts.msac.plots`.

Frames: the MuJoCo world is inertial (free space, gravity off, no orbit). The bus yaw ``ψ``
is about world Z; the wing angle ``φ`` is the hinge angle relative to the bus; ``s`` the slide
of the whole rigid wing (``extension_model = "rigid_slide"``). Units SI; config angles in
degrees at the edge (``*_deg``).

The package imports only its config schema; the registry (:mod:`magsail_mj.concepts`) imports
the ``tasks`` module, with the model, the plots and Matplotlib, when a scenario is built.
"""

from __future__ import annotations

from magsail_mj.concepts.msac.config import PAPER_VALUES, MsacConfig, make_path, point_config

__all__ = ["MsacConfig", "PAPER_VALUES", "point_config", "make_path"]
