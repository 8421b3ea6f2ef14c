"""The report of a finished sweep: comparison tables and plots from its ``sweep_summary.json``.

``write_report(sweep_dir)`` writes into ``sweep_dir/report/``:

* **grid** (``[grid]`` or ``[[run]]`` sweeps): ``report.md`` and ``report.csv``, one row per run
  with its varied values, its status and the chosen summary figures, and ``<key>.png`` per
  varied key: each figure (a panel) against that key, one marker series per combination of
  the other keys. A run that failed has no point (its row says why).
* **Monte Carlo** (``[monte_carlo]`` sweeps): ``report.md`` and ``percentiles.csv``, per
  chosen figure the number of runs, how many reached a value (finite), never did (the run
  completed but the figure is None, e.g. ``|ω|`` never stayed below a threshold within the run)
  and failed (any run that did not complete, or whose structure failed), the share reached, and
  the 5/50/95 % percentiles;
  ``<figure>.png`` per figure: a histogram of the reached values and the empirical CDF.
* **grid × Monte Carlo** (``[grid]`` and ``[monte_carlo]``: every grid point runs the same
  samples, ids ``<grid id>/s<i>``): the Monte Carlo statistics per grid point (runs grouped by
  the id's grid part, e.g. ``bdot_law=b_cross``), with the mean of the reached values beside the
  percentiles: ``report.md`` with one table per figure (a row per grid point), ``percentiles.csv``
  (a row per grid point and figure), and ``<figure>_cdf.png`` per figure with one empirical CDF
  per grid point.

Runs that failed or never reached a value are not dropped: they count in every denominator, as
``+inf`` in the percentiles (a percentile beyond the share reached is written ``never``), and
the CDF ends at the share reached. Runs the sweep did not run to their end because the sweep was
stopped (``not_run``, ``interrupted``) are no results: they are left out of ``n`` and counted
apart (``not_run``), so the report of a stopped sweep is that of the samples that ran.
With ``x_1 ≤ … ≤ x_n`` the values of the ``n`` runs (never
and failed as ``+inf``), the empirical CDF is ``F(x) = #{i : x_i ≤ x} / n`` and the ``p`` %
percentile is ``x_k`` with ``k = ⌈p n / 100⌉`` (the inverted CDF, no interpolation).

The figures are the sweep file's ``[report] figures`` list, else (grid) every numeric scalar of
the run summaries that varies across runs, or (Monte Carlo) every one ending in ``_s``. The
``[report]`` table may also give ``percentiles`` (numbers in (0, 100], default 5, 50, 95) and, for
a Monte Carlo, ``shares``: summary keys holding true/false (e.g. ``detumbled``), each reported as
the number and share of runs where it is true (failed runs count as not true; not-run runs are
left out as above).
``magsail report sweep SWEEP_DIR`` (:func:`add_arguments`, :func:`main`) and ``python -m
magsail_mj.sweep.report SWEEP_DIR`` run it.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from magsail_mj.cli import add_sweep_report_arguments as add_arguments
from magsail_mj.config import ConfigError, read_toml
from magsail_mj.io import atomic_path, file_sha256

__all__ = ["PERCENTILES", "write_report", "figure_stats", "share_stats", "add_arguments", "main", "ReportError"]

PERCENTILES = (5.0, 50.0, 95.0)
REPORT_DIR = "report"
_NOT_RUN = ("not_run", "interrupted")  # the sweep stopped before the run ended: no result either way
_MAX_PANELS = 12  # figures per grid plot (a larger list is split over several files)
_DPI = 80


class ReportError(ValueError):
    """The folder holds no sweep results (or a bad ``[report]`` table); the message names the path or key."""


# ---------------------------------------------------------------------------------------------
# Inputs


def _load(sweep_dir: Path) -> tuple[list[dict[str, Any]], dict[str, Any], dict[str, Any]]:
    """Records, manifest, and the sweep file's tree (empty when the file is gone)."""
    try:
        records = json.loads((sweep_dir / "sweep_summary.json").read_text())
    except FileNotFoundError:
        raise ReportError(f"SWEEP_DIR: {str(sweep_dir)!r} holds no sweep_summary.json (not a sweep folder)") from None
    except (OSError, ValueError) as err:
        raise ReportError(f"SWEEP_DIR: {sweep_dir / 'sweep_summary.json'} is unreadable ({err})") from None
    if not isinstance(records, list) or not all(isinstance(r, dict) and "id" in r for r in records):
        raise ReportError(f"SWEEP_DIR: {sweep_dir / 'sweep_summary.json'} is not a list of run records")
    try:
        manifest = json.loads((sweep_dir / "sweep_manifest.json").read_text())
    except (OSError, ValueError):
        manifest = {}
    listed = manifest.get("files") if isinstance(manifest, dict) else None
    if isinstance(listed, dict) and "sweep_summary.json" in listed:
        if file_sha256(sweep_dir / "sweep_summary.json") != listed["sweep_summary.json"]:
            raise ReportError(
                f"SWEEP_DIR: {sweep_dir / 'sweep_summary.json'} differs from its SHA-256 in sweep_manifest.json "
                "(edited, truncated, or the sweep is still running)"
            )
    try:
        tree = read_toml(manifest["sweep"]) if manifest.get("sweep") else {}
    except (ConfigError, OSError):
        tree = {}
    return records, manifest, tree


def _report_table(tree: dict[str, Any]) -> dict[str, Any]:
    table = tree.get("report", {})
    if not isinstance(table, dict):
        raise ReportError(f"report: must be a table, got {table!r}")
    unknown = sorted(set(table) - {"figures", "percentiles", "shares"})
    if unknown:
        raise ReportError(f"report: unknown keys {unknown!r} (known: figures, percentiles, shares)")
    return table


def _key_list(table: dict[str, Any], name: str) -> list[str] | None:
    value = table.get(name)
    if value is None:
        return None
    if not isinstance(value, list) or not value or not all(isinstance(f, str) for f in value):
        raise ReportError(f"report.{name}: must be a non-empty list of summary keys, got {value!r}")
    return value


def _report_options(tree: dict[str, Any]) -> list[str] | None:
    """The ``[report] figures`` list of the sweep file (None when absent)."""
    return _key_list(_report_table(tree), "figures")


def _report_percentiles(tree: dict[str, Any]) -> tuple[float, ...]:
    """The ``[report] percentiles`` of the sweep file (:data:`PERCENTILES` when absent)."""
    value = _report_table(tree).get("percentiles")
    if value is None:
        return PERCENTILES
    if (
        not isinstance(value, list)
        or not value
        or not all(not isinstance(p, bool) and isinstance(p, (int, float)) and 0 < p <= 100 for p in value)
    ):
        raise ReportError(f"report.percentiles: must be a non-empty list of numbers in (0, 100], got {value!r}")
    return tuple(float(p) for p in value)


def _number(value: Any) -> float | None:
    """A finite float of a summary value, None otherwise (None, a string, a vector, NaN)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value) if math.isfinite(value) else None


def _numeric_keys(records: list[dict[str, Any]]) -> list[str]:
    """Summary keys that are a number in at least one run, in first-seen order."""
    keys: list[str] = []
    for rec in records:
        for key, value in (rec.get("summary") or {}).items():
            if key not in keys and _number(value) is not None:
                keys.append(key)
    return keys


def _default_figures(records: list[dict[str, Any]], *, monte_carlo: bool) -> list[str]:
    keys = _numeric_keys(records)
    if monte_carlo:
        return [k for k in keys if k.endswith("_s") and k != "wall_time_s"]
    varying = []
    for key in keys:
        values = {_number((r.get("summary") or {}).get(key)) for r in records}
        if len(values) > 1:
            varying.append(key)
    return varying


def _ok(rec: dict[str, Any]) -> bool:
    """A run whose numbers enter figures and statistics: completed, and its structure did not fail
    (a studied failure such as ``structure_failed``, or a summary saying ``failed``, is reported
    as failed, never averaged in)."""
    return rec.get("status") == "completed" and (rec.get("summary") or {}).get("failed") is not True


# ---------------------------------------------------------------------------------------------
# Monte Carlo


def figure_stats(
    records: list[dict[str, Any]], figure: str, percentiles: Sequence[float] = PERCENTILES
) -> dict[str, Any]:
    """Counts, share reached and percentiles of one summary figure over every run.

    A run counts as ``failed`` when it did not complete or its structure failed (status
    ``structure_failed`` or the other studied failures, or a summary with ``failed = true``),
    ``never`` when it completed but the figure is not a finite number, else ``reached``;
    ``not_run`` and ``interrupted`` runs (the sweep stopped first) are left out of ``n`` and
    counted as ``not_run``. Percentiles use every run, failed and never as +inf (inverted
    empirical CDF, ``x_k`` with ``k = ⌈p n/100⌉``); ``None`` stands for +inf in the result.
    ``share_reached = reached / n``.
    """
    values = []
    failed = never = not_run = 0
    for rec in records:
        if rec.get("status") in _NOT_RUN:
            not_run += 1
            continue
        if not _ok(rec):
            failed += 1
            values.append(math.inf)
            continue
        x = _number((rec.get("summary") or {}).get(figure))
        if x is None:
            never += 1
            values.append(math.inf)
        else:
            values.append(x)
    n = len(values)
    arr = np.sort(np.asarray(values, dtype=float))
    pct = {}
    for p in percentiles:
        k = max(1, math.ceil(p * n / 100.0)) if n else 0
        v = float(arr[k - 1]) if n else math.inf
        pct[f"p{p:g}"] = v if math.isfinite(v) else None
    reached = n - failed - never
    return {
        "figure": figure,
        "n": n,
        "reached": reached,
        "never": never,
        "failed": failed,
        "not_run": not_run,
        "share_reached": reached / n if n else None,
        "percentiles": pct,
        "min": float(arr[0]) if reached else None,
        "max": float(arr[reached - 1]) if reached else None,
        "mean_reached": float(np.mean(arr[:reached])) if reached else None,
    }


def share_stats(records: list[dict[str, Any]], key: str) -> dict[str, Any]:
    """How many runs have the summary value ``key`` true: ``n`` (runs that ran, as
    :func:`figure_stats` counts them), ``true``, ``false`` (completed, value not true), ``failed``
    (counted as not true), ``not_run``, ``share_true = true / n`` and ``share_not = 1 − share_true``."""
    true = false = failed = not_run = 0
    for rec in records:
        if rec.get("status") in _NOT_RUN:
            not_run += 1
        elif not _ok(rec):
            failed += 1
        elif (rec.get("summary") or {}).get(key) is True:
            true += 1
        else:
            false += 1
    n = true + false + failed
    return {
        "key": key,
        "n": n,
        "true": true,
        "false": false,
        "failed": failed,
        "not_run": not_run,
        "share_true": true / n if n else None,
        "share_not": (n - true) / n if n else None,
    }


def _fmt(value: Any) -> str:
    if value is None:
        return "never"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


NO_RUNS = "—"
"""A cell of a group none of whose runs ran (n = 0): no percentile, share or mean, not ``never``."""


def _cell(value: Any, n: int) -> str:
    """A percentile or mean cell: :data:`NO_RUNS` when no run ran, else :func:`_fmt`."""
    return NO_RUNS if n == 0 else _fmt(value)


def _share_cell(share: float | None) -> str:
    """A share in per cent, :data:`NO_RUNS` when no run ran (``share`` None)."""
    return NO_RUNS if share is None else f"{100 * share:.1f} %"


def _csv_pct(value: float | None, n: int) -> Any:
    """A percentile in the CSV: empty when no run ran, ``never`` for +inf, else the number."""
    if n == 0:
        return ""
    return "never" if value is None else value


def _mc_plot(records: list[dict[str, Any]], figure: str, stats: dict[str, Any], path: Path) -> None:
    """Histogram of the reached values and the empirical CDF over every run (percentiles marked)."""
    reached = np.sort(
        [x for r in records if _ok(r) and (x := _number((r.get("summary") or {}).get(figure))) is not None]
    )
    fig = Figure(figsize=(9.0, 3.4), dpi=_DPI)
    ax_h, ax_c = fig.subplots(1, 2)
    n = stats["n"]
    if reached.size:
        ax_h.hist(reached, bins=min(30, max(5, int(math.sqrt(reached.size)) + 1)), color="tab:blue")
        steps = np.arange(1, reached.size + 1) / n
        ax_c.step(np.concatenate([[reached[0]], reached]), np.concatenate([[0.0], steps]), where="post")
    ax_c.axhline(
        stats["share_reached"] or 0.0,
        color="grey",
        ls="--",
        lw=0.8,
        label=f"share reached {100 * (stats['share_reached'] or 0):.1f} %",
    )
    for name, value in stats["percentiles"].items():
        if value is not None:
            for ax in (ax_h, ax_c):
                ax.axvline(value, color="tab:red", ls=":", lw=0.9)
            ax_c.annotate(name, (value, 0.02), color="tab:red", fontsize=7, rotation=90)
    ax_h.set_title(
        f"{stats['reached']} reached, {stats['never']} never, {stats['failed']} failed (n = {n})", fontsize=9
    )
    ax_h.set_xlabel(figure, fontsize=8)
    ax_h.set_ylabel("runs")
    ax_c.set_xlabel(figure, fontsize=8)
    _finish_cdf(fig, ax_c, path, ylabel="F(x) over all runs")


def _save(fig: Any, path: Path) -> None:
    """Lay out ``fig`` and write it to ``path`` as PNG, atomically."""
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")


def _finish_cdf(fig: Any, ax: Any, path: Path, *, ylabel: str) -> None:
    """Label a CDF axis (``ylabel``, F from 0 to 1, legend) and save ``fig`` to ``path``."""
    ax.set_ylabel(ylabel)
    ax.set_ylim(0.0, 1.02)
    ax.legend(fontsize=7, loc="lower right")
    _save(fig, path)


def _mc_report(
    records: list[dict[str, Any]],
    figures: list[str],
    out: Path,
    title: str,
    *,
    percentiles: Sequence[float] = PERCENTILES,
    shares: Sequence[str] = (),
) -> list[Path]:
    stats = [figure_stats(records, f, percentiles) for f in figures]
    names = [f"p{p:g}" for p in percentiles]
    head = ["figure", "n", "reached", "never", "failed", "not_run", "share_reached", *names, "min", "max"]
    rows = [
        [
            s["figure"],
            s["n"],
            s["reached"],
            s["never"],
            s["failed"],
            s["not_run"],
            s["share_reached"],
            *[_csv_pct(s["percentiles"][k], s["n"]) for k in names],
            "" if s["min"] is None else s["min"],
            "" if s["max"] is None else s["max"],
        ]
        for s in stats
    ]
    paths = [_write_csv(out / "percentiles.csv", [head, *rows])]
    lines = [
        *_report_head(
            f"{title}: Monte Carlo report",
            records,
            "Failed runs and runs that never reach a value count in every share and as +inf in the percentiles "
            "(`never`); runs the sweep did not run to their end (not_run, interrupted) are left out of n.",
        ),
        "| figure | n | reached | never | failed | not run | share reached | " + " | ".join(names) + " |",
        "|---|---|---|---|---|---|---|" + "---|" * len(names),
    ]
    for s in stats:
        lines.append(
            f"| `{s['figure']}` | {s['n']} | {s['reached']} | {s['never']} | {s['failed']} | {s['not_run']} | "
            f"{_share_cell(s['share_reached'])} | "
            + " | ".join(_cell(s["percentiles"][k], s["n"]) for k in names)
            + " |"
        )
    lines.append("")
    if shares:
        share_rows: list[list[Any]] = [["key", "n", "true", "false", "failed", "not_run", "share_true"]]
        lines += ["| key | n | true | not true | failed | share true |", "|---|---|---|---|---|---|"]
        for key in shares:
            st = share_stats(records, key)
            share_rows.append([key, st["n"], st["true"], st["false"], st["failed"], st["not_run"], st["share_true"]])
            lines.append(
                f"| `{key}` | {st['n']} | {st['true']} | {st['false']} | {st['failed']} | "
                f"{_share_cell(st['share_true'])} |"
            )
        lines.append("")
        paths.append(_write_csv(out / "shares.csv", share_rows))
    for s in stats:
        png = out / f"{_file_name(s['figure'])}.png"
        _mc_plot(records, s["figure"], s, png)
        paths.append(png)
        lines += [f"![{s['figure']}]({png.name})", ""]
    paths.append(_write_md(out, lines))
    return paths


def _group_of(rec: dict[str, Any]) -> str:
    """The grid point of a grid × Monte Carlo run: its id without the sample part ``/s<i>``."""
    return str(rec["id"]).rsplit("/", 1)[0]


def _groups(records: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    groups: dict[str, list[dict[str, Any]]] = {}
    for rec in records:
        groups.setdefault(_group_of(rec), []).append(rec)
    return groups


def _cdf_plot(groups: dict[str, list[dict[str, Any]]], figure: str, path: Path) -> None:
    """The empirical CDF of ``figure`` over every run of each group, one curve per group; a curve
    ends at its group's share reached (failed and never-reached runs count in its n)."""
    fig = Figure(figsize=(6.4, 4.0), dpi=_DPI)
    ax = fig.subplots()
    for name, records in groups.items():
        n = sum(1 for r in records if r.get("status") not in _NOT_RUN)
        reached = np.sort(
            [x for r in records if _ok(r) and (x := _number((r.get("summary") or {}).get(figure))) is not None]
        )
        if not n:
            continue
        if reached.size:
            steps = np.arange(1, reached.size + 1) / n
            ax.step(
                np.concatenate([[reached[0]], reached]),
                np.concatenate([[0.0], steps]),
                where="post",
                label=f"{name} ({100 * reached.size / n:.0f} % reached)",
            )
        else:
            ax.plot([], [], label=f"{name} (none reached)")
    ax.set_xlabel(figure, fontsize=8)
    ax.grid(alpha=0.3)
    _finish_cdf(fig, ax, path, ylabel="F(x) over all runs of the grid point")


def _grouped_report(
    records: list[dict[str, Any]],
    figures: list[str],
    out: Path,
    title: str,
    *,
    percentiles: Sequence[float],
    shares: Sequence[str],
) -> list[Path]:
    """The grid × Monte Carlo report (module docstring)."""
    groups = _groups(records)
    names = [f"p{p:g}" for p in percentiles]
    head = ["grid_point", "figure", "n", "reached", "never", "failed", "not_run", "share_reached", *names]
    head += ["mean_reached", "min", "max"]
    rows: list[list[Any]] = []
    lines = _report_head(
        f"{title}: Monte Carlo report per grid point",
        records,
        f"{len(groups)} grid points, each over the same samples. Failed runs and runs that never reach a value "
        "count in every share and as +inf in the percentiles (`never`); the mean is over the runs that reached "
        "a value; runs the sweep did not run to their end (not_run, interrupted) are left out of n.",
    )
    for figure in figures:
        lines += [
            f"## `{figure}`",
            "",
            "| grid point | n | reached | never | failed | share reached | "
            + " | ".join(names)
            + " | mean (reached) |",
            "|---|---|---|---|---|---|" + "---|" * len(names) + "---|",
        ]
        for name, group in groups.items():
            st = figure_stats(group, figure, percentiles)
            pct = [st["percentiles"][k] for k in names]
            rows.append(
                [name, figure, st["n"], st["reached"], st["never"], st["failed"], st["not_run"], st["share_reached"]]
                + [_csv_pct(v, st["n"]) for v in pct]
                + ["" if st[k] is None else st[k] for k in ("mean_reached", "min", "max")]
            )
            lines.append(
                f"| {name} | {st['n']} | {st['reached']} | {st['never']} | {st['failed']} | "
                f"{_share_cell(st['share_reached'])} | "
                + " | ".join(_cell(v, st["n"]) for v in pct)
                + f" | {_cell(st['mean_reached'], st['n'])} |"
            )
        lines.append("")
    paths = [_write_csv(out / "percentiles.csv", [head, *rows])]
    if shares:
        share_rows: list[list[Any]] = [["grid_point", "key", "n", "true", "false", "failed", "not_run", "share_true"]]
        for key in shares:
            lines += [
                f"## `{key}`",
                "",
                "| grid point | n | true | not true | failed | share true | share not true |",
                "|---|---|---|---|---|---|---|",
            ]
            for name, group in groups.items():
                st = share_stats(group, key)
                share_rows.append([name, key, st["n"], st["true"], st["false"], st["failed"], st["not_run"]])
                share_rows[-1].append(st["share_true"])
                lines.append(
                    f"| {name} | {st['n']} | {st['true']} | {st['false']} | {st['failed']} | "
                    f"{_share_cell(st['share_true'])} | {_share_cell(st['share_not'])} |"
                )
            lines.append("")
        paths.append(_write_csv(out / "shares.csv", share_rows))
    for figure in figures:
        png = out / f"{_file_name(figure)}_cdf.png"
        _cdf_plot(groups, figure, png)
        paths.append(png)
        lines += [f"![{figure}]({png.name})", ""]
    paths.append(_write_md(out, lines))
    return paths


# ---------------------------------------------------------------------------------------------
# Grid


def _grid_keys(records: list[dict[str, Any]]) -> list[str]:
    keys: list[str] = []
    for rec in records:
        keys.extend(k for k in (rec.get("params") or {}) if k not in keys)
    return keys


def _label(value: Any) -> str:
    return json.dumps(value) if isinstance(value, (list, dict)) else str(value)


def _axis(values: list[Any]) -> tuple[list[float], list[str] | None]:
    """Positions of the values on the x axis: the numbers themselves, or the category index."""
    if all(_number(v) is not None for v in values):
        return [float(v) for v in values], None
    cats = list(dict.fromkeys(_label(v) for v in values))
    return [float(cats.index(_label(v))) for v in values], cats


def _grid_plot(records: list[dict[str, Any]], key: str, others: list[str], figures: list[str], path: Path) -> None:
    """Each figure (a panel) against ``key``; one series per combination of the other keys."""
    cols = min(3, len(figures))
    rows = math.ceil(len(figures) / cols)
    fig = Figure(figsize=(4.0 * cols, 2.8 * rows), dpi=_DPI)
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    runs = [r for r in records if _ok(r) and key in (r.get("params") or {})]
    xs, cats = _axis([r["params"][key] for r in runs])
    groups: dict[str, list[int]] = {}
    for i, rec in enumerate(runs):
        name = ", ".join(f"{k.split('.')[-1]}={_label(rec['params'].get(k))}" for k in others) or key
        groups.setdefault(name, []).append(i)
    for ax, figure in zip(axes, figures, strict=False):
        for name, idx in groups.items():
            pts = sorted((xs[i], y) for i in idx if (y := _number(runs[i]["summary"].get(figure))) is not None)
            if pts:
                ax.plot(*zip(*pts, strict=True), marker="o", ms=3, lw=0.8, label=name)
        ax.set_title(figure, fontsize=8)
        ax.set_xlabel(key, fontsize=8)
        if cats is not None:
            ax.set_xticks(range(len(cats)), cats, fontsize=7, rotation=30)
    for ax in axes[len(figures) :]:
        ax.set_visible(False)
    if 1 < len(groups) <= 8:
        axes[0].legend(fontsize=6)
    _save(fig, path)


def _report_head(heading: str, records: list[dict[str, Any]], note: str) -> list[str]:
    """The first lines of a report page: the heading, the run count with the statuses, and ``note``."""
    return [f"# {heading}", "", f"{len(records)} runs; statuses: {_status_counts(records)}. {note}", ""]


def _write_csv(path: Path, rows: list[list[Any]]) -> Path:
    """Write ``rows`` (the header row first) as CSV to ``path`` (atomically); returns ``path``."""
    buf = io.StringIO()
    csv.writer(buf).writerows(rows)
    with atomic_path(path) as tmp:
        tmp.write_text(buf.getvalue())
    return path


def _grid_report(records: list[dict[str, Any]], figures: list[str], out: Path, title: str) -> list[Path]:
    keys = _grid_keys(records)
    head = ["id", "status", *keys, *figures]
    rows = [
        [
            r["id"],
            r.get("status", ""),
            *[_label(r.get("params", {}).get(k, "")) for k in keys],
            *[_fmt(v) if (v := _number((r.get("summary") or {}).get(f))) is not None else "" for f in figures],
        ]
        for r in records
    ]
    paths = [_write_csv(out / "report.csv", [head, *rows])]
    lines = [
        *_report_head(
            f"{title}: grid report",
            records,
            "Failed runs keep their row (empty figures) and have no point in the plots.",
        ),
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    lines.append("")
    for key in keys:
        others = [k for k in keys if k != key]
        for part in range(0, len(figures), _MAX_PANELS):
            suffix = f"_{part // _MAX_PANELS + 1}" if len(figures) > _MAX_PANELS else ""
            png = out / f"{_file_name(key)}{suffix}.png"
            _grid_plot(records, key, others, figures[part : part + _MAX_PANELS], png)
            paths.append(png)
            lines += [f"![{key}]({png.name})", ""]
    paths.append(_write_md(out, lines))
    return paths


# ---------------------------------------------------------------------------------------------
# Entry points


def _status_counts(records: list[dict[str, Any]]) -> str:
    counts: dict[str, int] = {}
    for rec in records:
        counts[str(rec.get("status"))] = counts.get(str(rec.get("status")), 0) + 1
    return ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))


def _file_name(key: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in key)


def _write_md(out: Path, lines: list[str]) -> Path:
    path = out / "report.md"
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path


def write_report(sweep_dir: str | Path, *, figures: Sequence[str] | None = None) -> list[Path]:
    """Write the report of the sweep in ``sweep_dir`` into ``sweep_dir/report/``; return its files.

    A Monte Carlo report when the sweep file has ``[monte_carlo]`` (or, without the file, the run
    ids are the sample ids ``s<i>``), per grid point when it also has ``[grid]`` (or, without the
    file, the ids are ``<grid id>/s<i>``), else a grid report. ``figures`` (summary keys) overrides the
    sweep file's ``[report] figures`` and the defaults (module docstring).

    Raises:
      ReportError: ``sweep_dir`` holds no readable ``sweep_summary.json``, the ``[report]`` table is
        malformed, a figure is no summary key of any run, or there is no figure to report.
    """
    root = Path(sweep_dir)
    records, manifest, tree = _load(root)
    if not records:
        raise ReportError(f"SWEEP_DIR: {str(root)!r} lists no runs")
    monte_carlo = (
        "monte_carlo" in tree
        if tree
        else all(
            str(r["id"]).rsplit("/", 1)[-1][:1] == "s" and str(r["id"]).rsplit("/", 1)[-1][1:].isdigit()
            for r in records
        )
    )
    chosen = list(figures) if figures else _report_options(tree) or _default_figures(records, monte_carlo=monte_carlo)
    shares = (_key_list(_report_table(tree), "shares") or []) if monte_carlo else []
    known = {k for r in records for k in (r.get("summary") or {})}
    unknown = [f for f in [*chosen, *shares] if f not in known] if known else []
    if unknown:
        raise ReportError(f"figures: {unknown!r} not in any run summary (e.g. {sorted(known)[:8]!r})")
    if not chosen:
        raise ReportError(f"figures: no numeric summary figure to report in {str(root)!r} (no run completed?)")
    out = root / REPORT_DIR
    out.mkdir(exist_ok=True)
    title = str(manifest.get("name") or root.name)
    if not monte_carlo:
        return _grid_report(records, chosen, out, title)
    options = {"percentiles": _report_percentiles(tree), "shares": shares}
    grouped = "grid" in tree if tree else any("/" in str(r["id"]) for r in records)
    return (_grouped_report if grouped else _mc_report)(records, chosen, out, title, **options)


def main(args: argparse.Namespace) -> int:
    """``magsail report``: write the report, print its files; 2 with ``error: …`` on a bad folder or figure."""
    try:
        paths = write_report(args.sweep_dir, figures=args.figure)
    except ReportError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(json.dumps({"report": [str(p) for p in paths]}, indent=2))
    return 0


if __name__ == "__main__":
    _parser = argparse.ArgumentParser(prog="python -m magsail_mj.sweep.report", description=__doc__.splitlines()[0])
    add_arguments(_parser)
    sys.exit(main(_parser.parse_args()))
