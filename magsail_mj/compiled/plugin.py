r"""The Python side shared by the loads plugins (``cubesat_loads.c``, ``reflector_loads.c``).

A loads plugin reads a parameter block (a custom numeric of the model) and keeps its memory in
the instance's plugin state; both are flat blocks of ``float64`` whose fields are listed as
``(name, length)`` pairs in the order of the C source's enums. This module holds what the
concepts' ``compiled`` modules do alike with them:

* :func:`field_offsets` and :func:`block_writer`: a field's offset in a block (the running sum of
  the lengths before it) and the writer of a block;
* :data:`PARAM_HEAD` and :func:`param_block`: the fields every parameter block starts with (the
  C sources' ``P_VERSION`` … ``P_TIMING``) and a block with them written;
* :func:`probe_function`: a C function ``int f(const mjModel*, const mjData*, int instance,
  mjtNum* out)`` of the plugin's library, called through ``ctypes`` for the records;
* :func:`plugin_model`: a copy of a model's MjSpec with the plugin's numerics and one instance of
  the plugin naming them, compiled;
* :class:`CompiledPlant`: the compiled model, the bare one and the views of the plugin state.
"""

from __future__ import annotations

import ctypes
import functools
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np

__all__ = [
    "PARAM_HEAD",
    "TIMINGS",
    "CompiledPlant",
    "Fields",
    "block_writer",
    "field_offsets",
    "param_block",
    "plugin_model",
    "probe_function",
]

Fields = tuple[tuple[str, int], ...]
"""``(name, length)`` of a block's fields, in the C source's order."""

TIMINGS = {"start": 0, "midpoint": 1, "stage": 2}
"""``sim.load_timing`` → the code of the ``TIMING`` parameter (``plugin_common.h``'s ``TIMING_*``)."""

PARAM_HEAD: Fields = (
    ("VERSION", 1),
    ("BODY", 1),
    ("QPOSADR", 1),
    ("DOFADR", 1),
    ("TIMING", 1),
)
"""The fields every loads plugin's parameter block starts with: the block's layout version, the
body's id, its free joint's first ``qpos`` and ``qvel`` addresses and the timing code
(:data:`TIMINGS`)."""


@functools.cache
def field_offsets(fields: Fields) -> dict[str, int]:
    """Each field's offset in the block (the sum of the lengths before it) and ``"END"``: the
    block's length. The same dict for the same fields (cached): do not modify it."""
    out, k = {}, 0
    for name, n in fields:
        out[name] = k
        k += n
    out["END"] = k
    return out


def block_writer(block: np.ndarray, fields: Fields) -> Callable[[str, Any], None]:
    """``put(name, value)``: writes ``value`` (as ``float``, flattened) into the field ``name`` of
    ``block``; a ``ValueError`` names the field when the value's length is not the field's."""
    offsets, lengths = field_offsets(fields), dict(fields)

    def put(name: str, value: Any) -> None:
        v = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        if len(v) != lengths[name]:
            raise ValueError(f"{name}: expected {lengths[name]} numbers, got {len(v)}")
        block[offsets[name] : offsets[name] + len(v)] = v

    return put


def param_block(
    fields: Fields, *, version: int, body: int, qpos_adr: int, dof_adr: int, timing: str
) -> tuple[np.ndarray, Callable[[str, Any], None]]:
    """``(block, put)``: a zero parameter block of ``fields`` (which start with :data:`PARAM_HEAD`)
    with its head written, and its writer (:func:`block_writer`).

    Raises:
      ValueError: an unknown ``timing`` (named).
    """
    if timing not in TIMINGS:
        raise ValueError(f"timing: must be one of {sorted(TIMINGS)}, got {timing!r}")
    if fields[: len(PARAM_HEAD)] != PARAM_HEAD:
        raise ValueError(f"fields: must start with {PARAM_HEAD}, got {fields[: len(PARAM_HEAD)]}")
    block = np.zeros(field_offsets(fields)["END"])
    put = block_writer(block, fields)
    put("VERSION", version)
    put("BODY", body)
    put("QPOSADR", qpos_adr)
    put("DOFADR", dof_adr)
    put("TIMING", TIMINGS[timing])
    return block, put


def probe_function(library: Path, symbol: str) -> Any:
    """The C function ``int symbol(const mjModel* m, const mjData* d, int instance, mjtNum* out)``
    of ``library`` through ``ctypes`` (pass ``model._address``, ``data._address``, the instance and
    the output buffer's ``ctypes.data``; it returns 0, or -1 for an instance that is not the
    plugin's)."""
    fn = getattr(ctypes.CDLL(str(library)), symbol)
    fn.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]
    fn.restype = ctypes.c_int
    return fn


def plugin_model(
    spec: mujoco.MjSpec, *, plugin: str, instance: str, numerics: Mapping[str, tuple[str, np.ndarray]]
) -> mujoco.MjModel:
    """A copy of ``spec`` (``spec`` itself unchanged) with one custom numeric per entry of
    ``numerics`` (``attribute → (numeric name, values)``) and the active instance ``instance`` of
    the registered plugin ``plugin`` whose attributes name them, compiled."""
    s = spec.copy()
    for name, values in numerics.values():
        s.add_numeric(name=name, size=len(values), data=np.asarray(values, dtype=float).tolist())
    s.activate_plugin(plugin)
    p = s.add_plugin(name=instance, plugin_name=plugin, active=True)
    p.config = {attribute: name for attribute, (name, _) in numerics.items()}
    return s.compile()


class CompiledPlant:
    """A model with one loads plugin instance (its first), and the model without it.

    Args:
      model: the model with the plugin (:func:`plugin_model`).
      bare_model: the model without it (the bare ``mj_step`` a benchmark compares with).
      timing: ``"start"``, ``"midpoint"`` or ``"stage"`` (``sim.load_timing``).

    Attributes:
      model, bare_model, timing; ``state_adr``: the instance's first plugin state address.
      state_fields (class): the plugin state's fields (:data:`Fields`); a subclass sets them.
    """

    state_fields: ClassVar[Fields] = ()

    def __init__(self, model: mujoco.MjModel, *, bare_model: mujoco.MjModel, timing: str) -> None:
        self.model = model
        self.bare_model = bare_model
        self.timing = timing
        self.state_adr = int(model.plugin_stateadr[0])

    def state(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """A view of the field ``name`` of :attr:`state_fields` in ``data``'s plugin state."""
        i = self.state_adr + field_offsets(self.state_fields)[name]
        return data.plugin_state[i : i + dict(self.state_fields)[name]]
