r"""The gossamer reflector with a conducting support structure (concept ``reflector``): the
concept package.

Paper: Robb et al. 2020 (Robb, McRobb, McInnes, AIAA SciTech 2020-0714). A
rigid square plate (:mod:`magsail_mj.concepts.reflector.mjcf`) whose truss carries two serpentine coils and an
in-plane loop (:mod:`magsail_mj.geometry.reflector_coil`); each path acts as an ideal dipole along
its axis limited to ``m_max = T_max / B_ref`` (Robb et al. 2020, Eqs. 1–4; ``T_max`` from
:mod:`magsail_mj.analysis.coil_torque`). Two kinds of run (``kind``):

* ``"detumble"`` — Scenario A: constant field (inertial ``+Z``, A6; body-fixed as a
  variant), B-dot law of :mod:`magsail_mj.concepts.reflector.bdot`, world = inertial, no orbit.
* ``"pitch"`` — Scenario B: polar dawn–dusk orbit, dipole field Eq. 11, steering law
  (:mod:`magsail_mj.control.reflector_steering`), quaternion feedback with projection ⟂ B and
  saturation (:mod:`magsail_mj.control.reflector_pitch`); optional gravity-gradient torque (B5).
* ``"pitch_caps"`` — case B3: the whole cap sweep with bisection in one run
  (:mod:`magsail_mj.concepts.reflector.caps`).

Parts: config schema :mod:`magsail_mj.concepts.reflector.config`; model builder (config → coil
geometry → MjSpec, controllers) :mod:`magsail_mj.concepts.reflector.model`; one task class per
kind :mod:`magsail_mj.concepts.reflector.tasks`; metrics and plots
:mod:`magsail_mj.concepts.reflector.metrics`, :mod:`magsail_mj.concepts.reflector.plots`.

Configs live at ``magsail_mj/concepts/reflector/configs/<id>.toml`` (``detumble``, ``tracking_100g``, ``tracking_10g``
and the variants under ``detumble/`` and ``pitch/``). Torques enter through
``xfrc_applied`` (:class:`magsail_mj.loads.body_torque.HeldBodyTorqueLoad`), rewritten every
step; the controller runs every integration step (zero-order hold).

The package imports only its config schema; the registry (:mod:`magsail_mj.concepts`) imports
the ``tasks`` module, with the model, the plots and Matplotlib, when a scenario is built.
"""

from __future__ import annotations

from magsail_mj.concepts.reflector.config import ReflectorConfig

__all__ = ["ReflectorConfig"]
