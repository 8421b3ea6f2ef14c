"""``magsail build`` and ``magsail validate``: a config's model and its check (no run, so no Dask,
Matplotlib or mediapy is loaded).

Both also take a structure on its own (a structure file, a gmsh mesh or a Nastran deck:
:mod:`magsail_mj.verbs.sources`): the structure free in space with no loads, as the structure
concept models it (:func:`magsail_mj.structure.mjcf.build_structure_spec`, RK4), at a time step
proposed from its highest natural frequency (:func:`magsail_mj.structure.stability.stable_timestep_s`:
half the undamped RK4 limit ``2.785 / ω_max``) and checked on the compiled model
(:func:`~magsail_mj.structure.stability.step_growth`; halved until stable). ``validate`` prints the
structure's counts, mass, centre of mass, highest frequency, the proposed steps of both explicit
integrators and the memory its model needs; ``build`` writes the model (``--set`` is refused: a
structure file has no config keys).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from magsail_mj.cli import CliInputError
from magsail_mj.io import atomic_path
from magsail_mj.resources import (
    check_memory,
    estimate_model_bytes,
    estimate_run_bytes,
    structure_model_bytes,
)
from magsail_mj.scenario import build_scenario
from magsail_mj.structure.assembly import assemble
from magsail_mj.structure.mjcf import build_structure_spec
from magsail_mj.structure.model import MEMBER_KINDS, Structure, StructureError
from magsail_mj.structure.stability import (
    STABILITY_LIMITS,
    UNSTABLE_GROWTH,
    highest_frequency_rad_s,
    largest_stable_fraction,
    stable_timestep_s,
    step_growth,
)
from magsail_mj.verbs.common import input_file, load, output_file, print_json
from magsail_mj.verbs.sources import is_structure_source, read_source

__all__ = ["build", "default_mjcf_path", "validate"]

STRUCTURE_INTEGRATOR = "RK4"
"""The integrator of a structure's model built on its own (no task config to choose one)."""
_FREE_STEP_S = 1.0
"""Step of a structure without stiffness (free particles: any step is stable) [s]."""


def default_mjcf_path(config: str | Path) -> Path:
    """Where ``magsail build CONFIG`` writes without ``-o``: beside the config, same stem, ``.xml``."""
    return Path(config).with_suffix(".xml")


def _structure_source(args: argparse.Namespace) -> Path | None:
    """The path of ``args.config`` when it is a structure on its own (``--set`` then refused)."""
    path = input_file(args.config, "config")
    if not is_structure_source(path):
        return None
    if args.set:
        raise CliInputError(
            f"--set: {args.set[0]!r} overrides a config key, but {str(path)!r} is a structure, not a config; "
            "edit the file, or give a config that uses it"
        )
    return path


class _FreeStructure:
    """A structure on its own, built free in space at a stable step (module docstring)."""

    def __init__(self, path: Path) -> None:
        self.structure, self.kind = read_source(str(path))
        s = self.structure
        check_memory(structure_model_bytes(n_nodes=s.n_nodes, n_members=s.n_members), what=f"build {path}")
        try:
            self.omega_max_rad_s = highest_frequency_rad_s(assemble(s))
        except StructureError as err:
            raise CliInputError(f"config: {err}") from None
        step = stable_timestep_s(self.omega_max_rad_s, STRUCTURE_INTEGRATOR)
        self.spec = self._spec(step if math.isfinite(step) else _FREE_STEP_S)
        try:
            self.model = self.spec.compile()
        except ValueError as err:
            raise CliInputError(f"config: {str(path)!r}: MuJoCo cannot compile the structure's model: {err}") from None
        if step_growth(self.model) > UNSTABLE_GROWTH:
            fraction = largest_stable_fraction(self.model)
            if fraction is None:
                raise CliInputError(
                    f"config: {str(path)!r}: no time step down to 1/64 of {step:.3g} s is stable for the structure "
                    "with RK4 (its stiffest modes grow on their own)"
                )
            self.spec = self._spec(step * fraction)
            self.model = self.spec.compile()
        self.timestep_s = float(self.model.opt.timestep)

    def _spec(self, timestep_s: float) -> mujoco.MjSpec:
        try:
            return build_structure_spec(self.structure, timestep_s=timestep_s, integrator=STRUCTURE_INTEGRATOR)
        except StructureError as err:
            raise CliInputError(f"config: {err}") from None

    def model_bytes(self) -> float:
        """Memory of the model (:func:`~magsail_mj.resources.structure_model_bytes` of its sizes)."""
        m = self.model
        return structure_model_bytes(
            n_nodes=self.structure.n_nodes,
            n_members=self.structure.n_members,
            nv=int(m.nv),
            nbody=int(m.nbody),
            ntendon=int(m.ntendon),
            mass_nnz=int(m.nM),
            arena_bytes=int(m.narena),
        )

    def size(self) -> dict[str, Any]:
        """The structure's counts and the model's sizes."""
        s, m = self.structure, self.model
        kinds = np.asarray(s.members.kind)
        return {
            "nodes": s.n_nodes,
            "members": {kind: int(np.count_nonzero(kinds == k)) for k, kind in enumerate(MEMBER_KINDS)},
            "panels": len(s.panels),
            "rigid_parts": len(s.rigid_parts),
            "bodies": int(m.nbody),
            "dofs": int(m.nv),
            "tendons": int(m.ntendon),
        }

    def steps(self) -> dict[str, Any]:
        """The highest frequency and the steps it proposes, and the step the model was built at."""
        f_max = self.omega_max_rad_s / (2.0 * math.pi)
        return {
            "f_max_Hz": f_max,
            "proposed_timestep_s": {
                name: stable_timestep_s(self.omega_max_rad_s, name) if f_max > 0 else None for name in STABILITY_LIMITS
            },
            "integrator": STRUCTURE_INTEGRATOR,
            "timestep_s": self.timestep_s,
        }


def _build_structure(args: argparse.Namespace, path: Path) -> int:
    out = output_file(args.output, "--output") if args.output is not None else default_mjcf_path(path)
    free = _FreeStructure(path)
    check_memory(free.model_bytes(), what=f"build {path}")
    with atomic_path(out) as tmp:
        tmp.write_text(free.spec.to_xml())
    print_json({"mjcf": str(out), "kind": free.kind, **free.size(), **free.steps()}, what="build")
    return 0


def _validate_structure(path: Path) -> int:
    free = _FreeStructure(path)
    s: Structure = free.structure
    total_kg, center_m, _ = s.mass_properties()
    estimate = check_memory(free.model_bytes(), what=f"validate {path}: its model")
    print_json(
        {
            "config": str(path),
            "kind": free.kind,
            "valid": True,
            **free.size(),
            "mass_kg": float(total_kg),
            "center_of_mass_m": np.asarray(center_m, dtype=float).tolist(),
            **free.steps(),
            "memory_estimate_bytes": estimate,
        },
        what="validate",
    )
    return 0


def build(args: argparse.Namespace) -> int:
    """Write the MJCF of the config and print the model size (one JSON object).

    Without ``-o`` the MJCF goes beside the config (:func:`default_mjcf_path`): that file is the
    model of the config as written, so it is written only without ``--set``; with overrides the
    output must be named with ``-o`` (a committed model beside its config is never replaced by
    the model of other values). A structure on its own is built free in space (module docstring).
    """
    structure_path = _structure_source(args)
    if structure_path is not None:
        return _build_structure(args, structure_path)
    out = output_file(args.output, "--output") if args.output is not None else None
    cfg = load(args)
    check_memory(estimate_model_bytes(cfg), what=f"build {args.config}")
    if out is None and args.set:  # the config's own problems are reported first
        raise CliInputError(
            f"--output: required with --set (without -o, build writes the model of the config as written to "
            f"{str(default_mjcf_path(args.config))!r}; name the model of the overridden config with -o OUT.xml)"
        )
    out = out or default_mjcf_path(args.config)
    scenario = build_scenario(cfg)
    with atomic_path(out) as tmp:
        tmp.write_text(scenario.spec.to_xml())
    size = scenario.manifest_extra().get("model_size", {})
    print_json({"mjcf": str(out), **size}, what="build")
    return 0


def validate(args: argparse.Namespace) -> int:
    """Check the config (every problem with its key path) and the memory a run of it needs; or a
    structure on its own (module docstring)."""
    structure_path = _structure_source(args)
    if structure_path is not None:
        return _validate_structure(structure_path)
    cfg = load(args)
    estimate = check_memory(estimate_run_bytes(cfg), what=f"validate {args.config}: a run")
    print_json(
        {
            "config": args.config,
            "concept": cfg.concept,
            "scenario": cfg.scenario,
            "valid": True,
            "memory_estimate_bytes": estimate,
        },
        what="validate",
    )
    return 0
