"""The committed results bundle: what the reproduction reports need from finished run folders.

``collect(run_dirs, bundle)`` matches every run folder to one ``[[run]]`` of the registry (same
concept and scenario, and every config key the run's manifest shares with the registry's config
and its ``set`` overrides equal, the presentation keys aside; a pinned ``config_hash`` must match
exactly) and copies into ``<bundle>/<paper>/<run id>/``:

* ``summary.json``: the run's summary (sorted keys);
* ``identity.json``: the manifest fields that identify the run (:data:`IDENTITY_KEYS`: concept,
  scenario, config and numbers hash, creation time, versions, status, simulated and wall time)
  and the registry config it matched;
* the registry's figures, downscaled to at most :data:`FIGURE_MAX_PX` pixels on the longer side
  and colour-quantised so each stays under :data:`FIGURE_MAX_BYTES`;
* the optional clip when it is under :data:`CLIP_MAX_BYTES`.

``<bundle>/index.json`` lists every bundled run (sorted JSON). The whole bundle must stay under
:data:`BUNDLE_MAX_BYTES`. Every file is written deterministically: the same run folders give the
same bytes.
"""

from __future__ import annotations

import io
import json
import shutil
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from PIL import Image

from magsail_mj.config import ConfigError, load_config
from magsail_mj.integrity import IntegrityError, verify_run_folder
from magsail_mj.report.registry import REPO_ROOT, Paper, RunSpec

__all__ = [
    "BUNDLE_MAX_BYTES",
    "CLIP_MAX_BYTES",
    "FIGURE_MAX_BYTES",
    "FIGURE_MAX_PX",
    "IDENTITY_KEYS",
    "BundleError",
    "Target",
    "bundle_bytes",
    "config_differences",
    "collect",
    "downscale_png",
    "expand_run_dirs",
    "read_bundle",
    "write_index",
]

FIGURE_MAX_PX = 1000
FIGURE_MAX_BYTES = 300_000
CLIP_MAX_BYTES = 2_000_000
BUNDLE_MAX_BYTES = 20_000_000
# presentation keys that do not change the numbers a run computes (never compared when matching)
IGNORED_CONFIG_KEYS = frozenset({"description", "sim.progress", "sim.checkpoint_every_s"})
IGNORED_CONFIG_TABLES = frozenset({"render"})
IDENTITY_KEYS = (
    "concept",
    "scenario",
    "config_hash",
    "numbers_hash",
    "created_utc",
    "status",
    "status_message",
    "t_end_s",
    "steps",
    "wall_time_s",
    "integrator",
    "timestep_s",
)
VERSION_KEYS = ("magsail_mj", "mujoco", "numpy", "python")


class BundleError(ValueError):
    """A run folder or the bundle cannot be used (the message names the folder or file)."""


@dataclass(frozen=True)
class Target:
    """Where a run folder goes: ``paper`` and its ``[[run]]`` entry."""

    paper: Paper
    spec: RunSpec


def _dump(obj: Any) -> str:
    return json.dumps(obj, indent=1, sort_keys=True, allow_nan=True) + "\n"


def _read_json(path: Path, *, what: str) -> dict[str, Any]:
    if not path.is_file():
        raise BundleError(f"{path.parent}: not a finished run folder ({path.name} is missing, {what})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise BundleError(f"{path}: unreadable {what}: {err}") from err
    if not isinstance(data, dict):
        raise BundleError(f"{path}: {what} is not a JSON object")
    return data


def _leaves(tree: Any, prefix: str = "") -> dict[str, Any]:
    """``{dotted key: value}`` of every leaf of a JSON tree (lists are leaves)."""
    if not isinstance(tree, dict):
        return {prefix: tree}
    out: dict[str, Any] = {}
    for key, value in tree.items():
        out |= _leaves(value, f"{prefix}.{key}" if prefix else str(key))
    return out


def _ignored(key: str) -> bool:
    return key in IGNORED_CONFIG_KEYS or key.split(".", 1)[0] in IGNORED_CONFIG_TABLES


def _spec_leaves(spec: RunSpec, cache: dict[tuple[str, tuple[str, ...]], dict[str, Any]]) -> dict[str, Any]:
    """The validated registry config with its overrides as leaves (cached per config and overrides)."""
    key = (spec.config, spec.set)
    if key not in cache:
        try:
            cfg = load_config(REPO_ROOT / spec.config, list(spec.set))
        except ConfigError as err:
            raise BundleError(f"registry config {spec.config} ({list(spec.set)}): {err}") from err
        cache[key] = _leaves(cfg.model_dump(mode="json"))
    return cache[key]


def config_differences(run_config: dict[str, Any], registry_leaves: dict[str, Any]) -> tuple[list[str], list[str]]:
    """``(differing keys, keys on one side only)`` between a run's manifest config and a registry
    config, leaving out the presentation keys (:data:`IGNORED_CONFIG_KEYS`, the ``render`` table).

    Keys present on one side only come from a schema that gained (or renamed) keys since the run;
    they are listed in the bundle's identity but do not refuse the run.
    """
    run_leaves = {k: v for k, v in _leaves(run_config).items() if not _ignored(k)}
    reg_leaves = {k: v for k, v in registry_leaves.items() if not _ignored(k)}
    differing = sorted(k for k in run_leaves.keys() & reg_leaves.keys() if run_leaves[k] != reg_leaves[k])
    one_side = sorted(run_leaves.keys() ^ reg_leaves.keys())
    return differing, one_side


def _match(
    run_dir: Path,
    manifest: dict[str, Any],
    papers: dict[str, Paper],
    cache: dict[tuple[str, tuple[str, ...]], dict[str, Any]],
) -> tuple[Target, list[str]]:
    """The registry run whose config agrees with the manifest's on every shared key (see
    :func:`config_differences`); also returns the keys not compared."""
    concept, scenario = manifest.get("concept"), manifest.get("scenario")
    run_config = manifest.get("config")
    if not isinstance(run_config, dict):
        raise BundleError(f"{run_dir}: manifest.json has no config table")
    candidates = []
    for paper in papers.values():
        for spec in paper.run:
            config = _concept_scenario(spec)
            if config.get("concept") == concept and config.get("scenario") == scenario:
                candidates.append(Target(paper, spec))
    if not candidates:
        raise BundleError(f"{run_dir}: no registry run has concept {concept!r} and scenario {scenario!r}")
    matches, reasons = [], []
    for target in candidates:
        differing, one_side = config_differences(run_config, _spec_leaves(target.spec, cache))
        if differing:
            reasons.append(f"{target.paper.paper}/{target.spec.id}: {', '.join(differing[:4])} differ")
        else:
            matches.append((target, one_side))
    if not matches:
        raise BundleError(f"{run_dir}: its config matches no registry run of its scenario ({'; '.join(reasons)})")
    if len(matches) > 1:
        ids = ", ".join(f"{t.paper.paper}/{t.spec.id}" for t, _ in matches)
        raise BundleError(f"{run_dir}: matches several registry runs ({ids}); give them different configs")
    target, one_side = matches[0]
    if target.spec.config_hash and target.spec.config_hash != manifest.get("config_hash"):
        raise BundleError(
            f"{run_dir}: config_hash {manifest.get('config_hash')} is not the registry's "
            f"{target.spec.config_hash} ({target.paper.paper}/{target.spec.id})"
        )
    return target, one_side


def _concept_scenario(spec: RunSpec) -> dict[str, str]:
    """The ``concept`` and ``scenario`` of a registry run's config file (read as TOML, unvalidated)."""
    path = REPO_ROOT / spec.config
    try:
        tree = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise BundleError(f"registry config {spec.config}: {err}") from err
    return {"concept": tree.get("concept"), "scenario": tree.get("scenario")}


def downscale_png(src: Path, *, max_px: int = FIGURE_MAX_PX, max_bytes: int = FIGURE_MAX_BYTES) -> bytes:
    """``src`` as PNG bytes at most ``max_px`` on its longer side, quantised to 256 colours; halved
    further until under ``max_bytes`` (a :class:`BundleError` below 100 px)."""
    with Image.open(src) as img:
        img.load()
        image = img.convert("RGB")
    size = max_px
    while size >= 100:
        small = image.copy()
        small.thumbnail((size, size), Image.Resampling.LANCZOS)
        buf = io.BytesIO()
        small.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE).save(
            buf, format="PNG", optimize=True
        )
        if buf.tell() <= max_bytes:
            return buf.getvalue()
        size //= 2
    raise BundleError(f"{src}: cannot be brought under {max_bytes} bytes")


def _identity(manifest: dict[str, Any], target: Target, run_dir: Path, one_side: list[str]) -> dict[str, Any]:
    ident = {k: manifest.get(k) for k in IDENTITY_KEYS}
    versions = manifest.get("versions") or {}
    ident["versions"] = {k: versions.get(k) for k in VERSION_KEYS if k in versions}
    ident["registry_config"] = target.spec.config
    ident["registry_set"] = list(target.spec.set)
    ident["source_folder"] = run_dir.name
    ident["config_keys_not_compared"] = one_side
    return ident


def _copy_run(
    run_dir: Path, target: Target, bundle: Path, manifest: dict[str, Any], summary: dict[str, Any], one_side: list[str]
) -> Path:
    dest = bundle / target.paper.paper / target.spec.id
    if dest.exists():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    (dest / "summary.json").write_text(_dump(summary), encoding="utf-8")
    (dest / "identity.json").write_text(_dump(_identity(manifest, target, run_dir, one_side)), encoding="utf-8")
    for name in target.spec.figures:
        if (run_dir / name).is_file():
            (dest / name).write_bytes(downscale_png(run_dir / name))
    clip = target.spec.clip
    if clip and (run_dir / clip).is_file() and (run_dir / clip).stat().st_size <= CLIP_MAX_BYTES:
        shutil.copyfile(run_dir / clip, dest / clip)
    return dest


def bundle_bytes(bundle: str | Path) -> int:
    """Total size of the files under ``bundle`` [bytes]."""
    return sum(p.stat().st_size for p in Path(bundle).rglob("*") if p.is_file())


def read_bundle(bundle: str | Path) -> dict[str, dict[str, dict[str, Any]]]:
    """``{paper: {run id: {"summary": ..., "identity": ..., "files": [...]}}}`` of every bundled run."""
    bundle = Path(bundle)
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for ident_path in sorted(bundle.glob("*/**/identity.json")):
        run_path = ident_path.parent
        rel = run_path.relative_to(bundle).as_posix()
        paper, _, run_id = rel.partition("/")
        out.setdefault(paper, {})[run_id] = {
            "summary": _read_json(run_path / "summary.json", what="summary"),
            "identity": _read_json(ident_path, what="identity"),
            "files": sorted(p.name for p in run_path.iterdir() if p.is_file()),
            "path": run_path,
        }
    return out


def write_index(bundle: str | Path) -> Path:
    """Write ``<bundle>/index.json``: per paper and run, the status, hashes, date and files."""
    bundle = Path(bundle)
    index: dict[str, Any] = {}
    for paper, runs in read_bundle(bundle).items():
        index[paper] = {
            run_id: {
                "status": run["identity"].get("status"),
                "config_hash": run["identity"].get("config_hash"),
                "created_utc": run["identity"].get("created_utc"),
                "files": run["files"],
            }
            for run_id, run in runs.items()
        }
    path = bundle / "index.json"
    path.write_text(_dump(index), encoding="utf-8")
    return path


def expand_run_dirs(paths: list[str | Path]) -> list[Path]:
    """The run folders of ``paths``: a sweep folder (``sweep_manifest.json``) stands for every run
    folder below it (``manifest.json`` one or two levels down, for ids such as ``a/b``), sorted; any
    other path is kept as given (and checked by :func:`collect`)."""
    out: list[Path] = []
    for item in paths:
        path = Path(item)
        if (path / "sweep_manifest.json").is_file() and not (path / "manifest.json").is_file():
            found = sorted(
                {p.parent for pattern in ("*/manifest.json", "*/*/manifest.json") for p in path.glob(pattern)}
            )
            if not found:
                raise BundleError(f"{path}: a sweep folder without finished runs")
            out += found
        else:
            out.append(path)
    return out


def collect(run_dirs: list[str | Path], bundle: str | Path, papers: dict[str, Paper]) -> list[Path]:
    """Copy what the reports need from each run folder into ``bundle`` (see the module docstring).

    A sweep folder stands for its run folders (:func:`expand_run_dirs`). Every folder is checked
    before anything is written; a folder without ``summary.json`` or
    ``manifest.json``, one that matches no registry run, or two folders for the same run raise
    :class:`BundleError` naming the folder. Raises as well when the bundle would exceed
    :data:`BUNDLE_MAX_BYTES` (the folders are then left in place: rerun with fewer).
    Returns the bundle folders written.
    """
    bundle = Path(bundle)
    run_dirs = expand_run_dirs(run_dirs)
    cache: dict[tuple[str, tuple[str, ...]], dict[str, Any]] = {}
    plan: list[tuple[Path, Target, dict[str, Any], dict[str, Any], list[str]]] = []
    seen: dict[tuple[str, str], Path] = {}
    for item in run_dirs:
        run_dir = Path(item)
        if not run_dir.is_dir():
            raise BundleError(f"{run_dir}: not a folder")
        manifest = _read_json(run_dir / "manifest.json", what="the run manifest")
        summary = _read_json(run_dir / "summary.json", what="the run summary")
        try:  # summary, figures and clip as the run wrote them (the records are not bundled)
            verify_run_folder(run_dir, records=False)
        except IntegrityError as err:
            raise BundleError(str(err)) from None
        target, one_side = _match(run_dir, manifest, papers, cache)
        key = (target.paper.paper, target.spec.id)
        if key in seen:
            raise BundleError(f"{run_dir}: the same registry run {key[0]}/{key[1]} as {seen[key]}")
        seen[key] = run_dir
        plan.append((run_dir, target, manifest, summary, one_side))
    written = [_copy_run(*item[:2], bundle, *item[2:]) for item in plan]
    write_index(bundle)
    total = bundle_bytes(bundle)
    if total > BUNDLE_MAX_BYTES:
        raise BundleError(f"{bundle}: {total} bytes, above the bundle budget of {BUNDLE_MAX_BYTES} bytes")
    return written
