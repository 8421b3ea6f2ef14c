r"""A body-fixed magnetic dipole in a uniform field as a compiled MuJoCo plugin, for any rigid model.

:func:`add_dipole_in_field` adds to an ``MjSpec`` one instance of the passive plugin
``magsail.dipole_in_field`` (``magsail_mj/compiled/dipole_in_field.c``, built and registered by
:func:`magsail_mj.compiled.load_plugin`). Every time MuJoCo computes the passive forces — at the
step's start and at each further stage of RK4 — the plugin adds the generalized force of the
world torque

.. math::

    \boldsymbol\tau = (R\,\mathbf m)\times\mathbf B \quad [\mathrm{N\,m}],
    \qquad U = -(R\,\mathbf m)\cdot\mathbf B \quad [\mathrm J]

on the body (``R`` body → world, ``m`` the dipole [A m², body axes], ``B`` the field [T, world
axes]; ``U`` the potential whose negative gradient the torque is), mapped to ``qfrc_passive`` as
MuJoCo maps ``xfrc_applied`` (``mj_applyFT`` at the body's centre of mass). The load is thus
evaluated at the state of every stage MuJoCo integrates, and a model stepped with RK4 integrates
it to fourth order, which a load held over the step in ``xfrc_applied`` does not (first order
held at the step's start, second at its predicted middle).

The dipole and the field are the instance's plugin state (:func:`dipole_state`), set from the
attributes at reset; writing that state between steps changes them (a commanded dipole, a field
that changes from step to step). A model carrying the plugin needs the library to load, so its
MJCF is for this package's processes only.
"""

from __future__ import annotations

import mujoco
import numpy as np

from magsail_mj.compiled.build import load_plugin

__all__ = ["LIBRARY", "PLUGIN", "add_dipole_in_field", "dipole_state", "potential_energy_J"]

LIBRARY = "dipole_in_field"
"""The C source's name in :data:`magsail_mj.compiled.SOURCE_DIR`."""
PLUGIN = "magsail.dipole_in_field"
"""The plugin's registered name."""


def _vec3_text(value: object, *, name: str) -> str:
    """Three finite numbers as the plugin attribute's text (``repr``: parsed back exactly)."""
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: must be three finite numbers, got {value!r}")
    return " ".join(repr(float(x)) for x in v)


def add_dipole_in_field(
    spec: mujoco.MjSpec,
    *,
    body: str,
    dipole_body_Am2: object,
    field_world_T: object,
    name: str | None = None,
) -> mujoco.MjsPlugin:
    """Add the torque ``(R m) × B`` on ``body`` to ``spec`` as a plugin instance (module docstring).

    Args:
      spec: the model's spec (edited in place; compile it afterwards).
      body: name of the body carrying the dipole (not the world body).
      dipole_body_Am2: (3,) dipole in the body's frame [A m²].
      field_world_T: (3,) uniform field in world axes [T].
      name: the instance's name (default ``magsail_dipole_<body>``), for :func:`dipole_state`.

    Returns:
      The plugin instance.

    Raises:
      ValueError: no such body in ``spec``, the world body, or a dipole or field that is not
        three finite numbers (the argument is named).
      CompiledLoadsError: the library cannot be built or loaded (no compiler).
    """
    if not body or spec.body(body) is None or body == spec.worldbody.name:
        raise ValueError(f"body: no body {body!r} other than the world in the MjSpec")
    config = {
        "body": body,
        "dipole": _vec3_text(dipole_body_Am2, name="dipole_body_Am2"),
        "field": _vec3_text(field_world_T, name="field_world_T"),
    }
    load_plugin(LIBRARY)
    spec.activate_plugin(PLUGIN)
    plugin = spec.add_plugin(name=name or f"magsail_dipole_{body}", plugin_name=PLUGIN, active=True)
    plugin.config = config
    return plugin


def _instance(model: mujoco.MjModel, name: str) -> int:
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_PLUGIN, name)
    if i < 0:
        raise ValueError(f"name: the model has no plugin instance {name!r}")
    return i


def dipole_state(model: mujoco.MjModel, data: mujoco.MjData, *, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Views of instance ``name``'s dipole [A m², body axes] and field [T, world axes] in
    ``data.plugin_state``: writing them changes the load from the next evaluation on.

    Raises:
      ValueError: the model has no plugin instance ``name``.
    """
    a = int(model.plugin_stateadr[_instance(model, name)])
    return data.plugin_state[a : a + 3], data.plugin_state[a + 3 : a + 6]


def potential_energy_J(model: mujoco.MjModel, data: mujoco.MjData, *, name: str) -> float:
    """``U = −(R m)·B`` [J] of instance ``name`` at ``data``'s kinematics: its body's ``xmat``, which
    ``mj_forward`` or ``mj_kinematics`` brings to the current ``qpos`` (after ``mj_step`` it is
    still the step's start attitude).

    Raises:
      ValueError: the model has no plugin instance ``name``.
    """
    i = _instance(model, name)
    body = int(data.plugin_data[i])  # the plugin's init stores its body id there
    a = int(model.plugin_stateadr[i])
    s = data.plugin_state[a : a + 6]
    return -float(np.dot(data.xmat[body].reshape(3, 3) @ s[:3], s[3:]))
