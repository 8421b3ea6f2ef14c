r"""The lattice's strut springs and dashpots computed by a compiled MuJoCo plugin instead of tendons.

:func:`plugin_truss_model` builds the truss of :func:`magsail_mj.lattice.mjcf.build_truss_spec`
(same bodies, slide joints, masses, options) **without** its one spatial tendon per strut and
adds one instance of the passive plugin ``magsail.lattice_springs``
(``magsail_mj/compiled/lattice_springs.c``, built and registered by
:func:`magsail_mj.compiled.load_plugin`), which adds for every strut ``s`` from node ``i`` to
node ``j`` (``r = x_j − x_i``, ``ℓ = |r|``, ``ê = r/ℓ``, world axes)

.. math::

    F_s = k_s(\ell - l_{0,s}) + \gamma_s (\dot{\mathbf x}_j - \dot{\mathbf x}_i)\cdot\hat{\mathbf e},
    \qquad Q_i \mathrel{+}= F_s\hat{\mathbf e},\quad Q_j \mathrel{-}= F_s\hat{\mathbf e}

to ``qfrc_passive`` [N] at every evaluation of the passive forces (each RK4 stage): the tendon's
``Jᵀ(−k(L − l0) − γ L̇)``, the two-sided spring–dashpot law of Robb et al. 2022a. Its data is one
custom numeric (:func:`strut_table`). The model's authored MJCF needs the plugin library to
load, so the shipped truss models keep their tendons; this model is what
``scripts/bench_lattice_compiled.py`` measures against them.

:func:`profiler_clock` is the library's clock of the calling thread's CPU time [µs] as a ``ctypes`` function, for
``mujoco.set_mjcb_time`` (MuJoCo's ``mjData.timer`` profiler records nothing without one).
"""

from __future__ import annotations

import ctypes
from dataclasses import replace

import mujoco
import numpy as np

from magsail_mj.compiled import load_plugin
from magsail_mj.lattice.geometry import Lattice
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec

__all__ = ["LIBRARY", "PLUGIN", "LAYOUT_VERSION", "strut_table", "plugin_truss_model", "profiler_clock"]

LIBRARY = "lattice_springs"
"""The C source's name in :data:`magsail_mj.compiled.SOURCE_DIR`."""
PLUGIN = "magsail.lattice_springs"
"""The plugin's registered name."""
LAYOUT_VERSION = 1
"""The strut table's layout (the C source's ``LAYOUT_VERSION``)."""
NUMERIC = "magsail_lattice_struts"
"""Name of the custom numeric holding the strut table."""

_clock = ctypes.CFUNCTYPE(ctypes.c_double)


def _node_dofs(model: mujoco.MjModel, n_nodes: int, *, body_offset: int) -> np.ndarray:
    """(n_nodes,) dof address of each node's x, y, z slide joints (−1: clamped, no joints).

    Raises:
      ValueError: a node body whose joints are not three world-aligned slide joints x, y, z at
        consecutive dofs (the plugin's velocity read-out assumes them).
    """
    dofs = np.full(n_nodes, -1, dtype=int)
    for a in range(n_nodes):
        b = a + body_offset
        nj, j0 = int(model.body_jntnum[b]), int(model.body_jntadr[b])
        if nj == 0:
            continue
        ok = nj == 3 and all(
            model.jnt_type[j0 + c] == mujoco.mjtJoint.mjJNT_SLIDE
            and np.array_equal(model.jnt_axis[j0 + c], np.eye(3)[c])
            and model.jnt_dofadr[j0 + c] == model.jnt_dofadr[j0] + c
            for c in range(3)
        )
        if not ok:
            raise ValueError(f"model: node {a} (body {b}) is not three world-aligned slide joints x, y, z")
        dofs[a] = int(model.jnt_dofadr[j0])
    return dofs


def strut_table(
    model: mujoco.MjModel,
    lattice: Lattice,
    *,
    stiffness: np.ndarray,
    damping: np.ndarray | float,
    body_offset: int = 1,
) -> np.ndarray:
    """The plugin's custom numeric: ``[version, n, S, body_0…body_{n−1}, dof_0…dof_{n−1},
    (i, j, k [N/m], l0 [m], γ [N s/m]) per strut]`` (node ``a`` is body ``a + body_offset``).

    Raises:
      ValueError: ``stiffness``/``damping`` of the wrong shape (named), or a node that is not three
        world-aligned slide joints.
    """
    n, S = lattice.n_nodes, lattice.n_struts
    k = np.asarray(stiffness, dtype=float)
    if k.shape != (S,):
        raise ValueError(f"stiffness: expected ({S},) spring constants, got shape {k.shape}")
    gamma = np.broadcast_to(np.asarray(damping, dtype=float), (S,))
    bodies = np.arange(n) + body_offset
    rows = np.column_stack((lattice.struts.astype(float), k, lattice.rest_length, gamma))
    head = [float(LAYOUT_VERSION), float(n), float(S)]
    dofs = _node_dofs(model, n, body_offset=body_offset)
    return np.concatenate((head, bodies.astype(float), dofs.astype(float), rows.ravel()))


def plugin_truss_model(
    lattice: Lattice,
    *,
    masses: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray | float,
    options: TrussModelOptions = TrussModelOptions(),
) -> mujoco.MjModel:
    """The truss of :func:`~magsail_mj.lattice.mjcf.build_truss_spec` (same arguments) with its
    strut forces from the ``magsail.lattice_springs`` plugin and no tendons (module docstring).

    Raises:
      CompiledLoadsError: the plugin library cannot be built (no compiler).
    """
    load_plugin(LIBRARY)
    bare = replace(
        lattice, struts=lattice.struts[:0], kind=lattice.kind[:0], rest_length=lattice.rest_length[:0], _cache={}
    )
    spec = build_truss_spec(bare, masses=masses, stiffness=np.zeros(0), damping=0.0, options=options)
    table = strut_table(spec.compile(), lattice, stiffness=stiffness, damping=damping)
    spec.add_numeric(name=NUMERIC, size=int(table.size), data=table.tolist())
    spec.activate_plugin(PLUGIN)
    plugin = spec.add_plugin(name="lattice_springs", plugin_name=PLUGIN, active=True)
    plugin.config = {"struts": NUMERIC}
    return spec.compile()


def profiler_clock() -> ctypes._CFuncPtr:
    """``magsail_clock_us`` of the plugin library (the thread's CPU time [µs]) for ``mujoco.set_mjcb_time``;
    keep the returned object alive while it is installed."""
    lib = ctypes.CDLL(str(load_plugin(LIBRARY)))
    return _clock(("magsail_clock_us", lib))
