r"""Batched worlds: N runs of one compiled model stepped together, Python once per step for all.

    import magsail_mj
    sim = magsail_mj.load(
        "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
        ["sim.duration_s=600"],
        world_overrides=[["initial.omega0_deg_s=[6, -7, 3]"], ["initial.omega0_deg_s=[2, 9, -4]"]],
    )
    result = sim.run()                 # every world to sim.duration_s
    result.worlds[1].records["qvel"]   # world 1's records, as its single run's
    state = sim.get_state()            # the whole batch as plain data

World k's config is the config with ``overrides`` and then ``world_overrides[k]`` (``--set``
strings), validated as a single run's; it runs exactly as that single run, bit for bit (the
worlds' arithmetic is written in the single run's order: :mod:`magsail_mj.batch.worldmath`).

Modules (one job each):

* :mod:`~magsail_mj.batch.worlds` — each world's config; what may differ between worlds and what
  is refused by name;
* :mod:`~magsail_mj.batch.models` — the batch's model and its per-world fields (masses, inertias …);
* :mod:`~magsail_mj.batch.environment` — the worlds' environments sampled together;
* :mod:`~magsail_mj.batch.worldmath` — element-wise arithmetic rounded as the single run's;
* :mod:`~magsail_mj.batch.records` — per-world recorders filled in blocks;
* :mod:`~magsail_mj.batch.runner` — the lockstep loop, per-world divergence, state;
* :mod:`~magsail_mj.batch.checkpoint` — the whole batch's checkpoint file, its checks on resume;
* :mod:`~magsail_mj.batch.build` — :func:`load_batch`, and how a concept joins (its ``batch``
  module; CNUSAIL's: :mod:`magsail_mj.concepts.cnusail.batch`, with the cubesat's loads, B-dot
  controller and step over the world axis in ``batch_loads``, ``batch_control``, ``batch_plant``;
  the truss lattice's: :mod:`magsail_mj.concepts.truss_magnetorquer.batch`, likewise);
* :mod:`magsail_mj.batch.folders` — each world's run folder as a single run writes it (imported on
  its own: it uses the run-folder writer, which itself loads configs through this package).

The batch runs the CNUSAIL cubesat's B-dot detumble (``control.mode = "bdot"``) and the flexible
truss lattice's orbital detumble and slews (``truss_magnetorquer``: the truss's SRP, drag and
mid-step loads are refused); other concepts,
the pointing laws and sensor noise are refused (see ``docs/batch.md``).
"""

from __future__ import annotations

from magsail_mj.batch.build import load_batch
from magsail_mj.batch.runner import BatchResult, BatchSimulation

__all__ = ["load_batch", "BatchSimulation", "BatchResult"]
