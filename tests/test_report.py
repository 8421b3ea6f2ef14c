"""Reproduction reports (``magsail_mj.report``): verdicts on synthetic summaries, the registry, the
results bundle (collect: refusals, size budget, determinism), the rendered pages, the committed
bundle and pages, and the ``magsail report`` command line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from magsail_mj import cli
from magsail_mj.config import config_hash, load_config, numbers_hash
from magsail_mj.io import file_sha256
from magsail_mj.report import bundle as bundle_mod
from magsail_mj.report.bundle import (
    BUNDLE_MAX_BYTES,
    FIGURE_MAX_BYTES,
    BundleError,
    bundle_bytes,
    collect,
    read_bundle,
)
from magsail_mj.report.registry import Claim, Paper, RegistryError, load_paper, load_registry
from magsail_mj.report.render import render_pages
from magsail_mj.report.verdict import (
    AGREES,
    DIFFERS,
    FAILED,
    NOT_RUN,
    MissingExplanation,
    MissingKey,
    judge,
    within,
)
from magsail_mj.sweep import load_sweep

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
PAGES = ROOT / "docs" / "reproduction"
CONFIG = "magsail_mj/concepts/msac/configs/lumped_limit.toml"


def _claim(**kw) -> Claim:
    base = dict(id="c", title="t", paper_ref="Fig. 1", paper_says="about 10 m", quantity="q", run="r", key="x_m")
    return Claim(**(base | kw))


def _run(summary: dict, status: str = "completed") -> dict:
    return {"summary": summary, "identity": {"status": status}}


def _judge(claim: Claim, summary: dict | None, status: str = "completed", **others: dict):
    """The verdict of ``claim`` with its run ``r`` (None: not in the bundle) and further runs by id."""
    runs = {} if summary is None else {"r": _run(summary, status)}
    return judge(claim, runs | others)


# --------------------------------------------------------------------------- verdicts


def test_verdict_agrees_within_an_absolute_tolerance_and_differs_outside():
    claim = _claim(paper_value=10.0, tolerance=0.5, tolerance_why="w", explanation="why")
    assert _judge(claim, {"x_m": 10.4}).verdict == AGREES
    assert _judge(claim, {"x_m": 9.5}).verdict == AGREES
    assert _judge(claim, {"x_m": 10.6}).verdict == DIFFERS
    assert _judge(claim, {"x_m": 10.6}).value == pytest.approx(10.6)


def test_verdict_relative_range_and_one_sided_comparisons():
    rel = _claim(paper_value=200.0, compare="rel", tolerance=0.05, tolerance_why="w")
    assert within(rel, 209.9) and not within(rel, 210.1) and within(rel, 190.1) and not within(rel, 189.9)
    rng = _claim(paper_range=(1.0, 2.0), tolerance=0.1, tolerance_why="w")
    assert within(rng, 0.9) and within(rng, 2.1) and not within(rng, 2.11) and not within(rng, 0.89)
    upper = _claim(paper_value=5.0, compare="max", tolerance=0.0, tolerance_why="requirement")
    assert within(upper, -100.0) and within(upper, 5.0) and not within(upper, 5.0001)
    lower = _claim(paper_value=5.0, compare="min", tolerance=1.0, tolerance_why="w")
    assert within(lower, 4.0) and within(lower, 1e9) and not within(lower, 3.99)
    assert not within(upper, float("nan"))


def test_verdict_scale_and_index_apply_before_the_comparison():
    claim = _claim(key="a_rad", index=1, scale=180.0 / np.pi, paper_value=90.0, tolerance=0.01, tolerance_why="w")
    assert _judge(claim, {"a_rad": [0.0, np.pi / 2]}).verdict == AGREES
    with pytest.raises(MissingKey, match=r"a_rad\[1\]"):
        _judge(claim, {"a_rad": [0.0]})


def test_differing_claim_without_explanation_is_an_error():
    claim = _claim(paper_value=1.0, tolerance=0.1, tolerance_why="w")
    assert _judge(claim, {"x_m": 1.05}).verdict == AGREES
    with pytest.raises(MissingExplanation, match="'c'"):
        _judge(claim, {"x_m": 2.0})


def test_null_value_differs_failed_runs_are_never_compared_and_a_missing_run_is_not_run():
    claim = _claim(paper_value=1.0, tolerance=0.1, tolerance_why="w", explanation="never reached")
    assert _judge(claim, {"x_m": None}).verdict == DIFFERS
    failed = _judge(claim, {"x_m": 1.0}, status="structure_failed")
    assert failed.verdict == FAILED and failed.value is None and failed.status == "structure_failed"
    assert _judge(claim, {}, status="diverged").verdict == FAILED  # key not even looked up
    not_run = _judge(claim, None)
    assert not_run.verdict == NOT_RUN and not_run.value is None  # never agrees by default


def test_a_structural_failure_is_compared_only_when_the_claim_says_so():
    claim = _claim(key="classification", expect="collapsed", criterion_why="w", explanation="x")
    assert _judge(claim, {"classification": "collapsed"}, status="structure_failed").verdict == FAILED
    compared = claim.model_copy(update={"compare_failed": True})
    assert _judge(compared, {"classification": "collapsed"}, status="structure_failed").verdict == AGREES
    assert _judge(compared, {"classification": "collapsed"}, status="diverged").verdict == FAILED


def test_qualitative_claims_check_a_bound_or_an_expected_value():
    bound = _claim(bound=5.0, compare="max", criterion_why="reaches its target", explanation="did not")
    assert _judge(bound, {"x_m": 4.9}).verdict == AGREES
    assert _judge(bound, {"x_m": 5.1}).verdict == DIFFERS
    assert _judge(bound, {"x_m": None}).verdict == DIFFERS  # the event never happened
    label = _claim(key="classification", expect="collapsed", criterion_why="w", explanation="x")
    v = _judge(label, {"classification": "flexible"})
    assert v.verdict == DIFFERS and v.value == "flexible"
    assert _judge(label, {"classification": "collapsed"}).verdict == AGREES
    flag = _claim(key="tumbled", expect=True, criterion_why="w", explanation="x")
    assert _judge(flag, {"tumbled": True}).verdict == AGREES and _judge(flag, {"tumbled": False}).verdict == DIFFERS
    with pytest.raises(MissingKey, match="x_m"):
        _judge(bound, {"y": 1})
    with pytest.raises(MissingKey, match="not a number"):
        _judge(bound, {"x_m": "flexible"})


def test_an_expect_not_claim_agrees_with_every_other_class():
    not_collapsed = _claim(key="classification", expect_not="collapsed", criterion_why="w", explanation="x")
    assert _judge(not_collapsed, {"classification": "flexible"}).verdict == AGREES
    assert _judge(not_collapsed, {"classification": "rigid_like"}).verdict == AGREES
    v = _judge(not_collapsed, {"classification": "collapsed"})
    assert v.verdict == DIFFERS and v.value == "collapsed"
    assert _judge(not_collapsed, {"classification": None}).verdict == DIFFERS  # no class is no evidence
    failed = not_collapsed.model_copy(update={"compare_failed": True})
    assert _judge(failed, {"classification": "collapsed"}, status="structure_failed").verdict == DIFFERS
    with pytest.raises(ValueError, match="exactly one of"):
        _claim(expect="flexible", expect_not="collapsed", criterion_why="w")
    with pytest.raises(ValueError, match="no ratio_key, no tolerance"):
        _claim(expect_not="collapsed", criterion_why="w", ratio_key="k")


def test_ratio_claims_divide_by_a_key_of_another_run():
    ratio = _claim(
        ratio_key="x_m",
        ratio_run="d",
        bound=0.8,
        compare="max",
        criterion_why="less, by more than the reading of a plot",
        explanation="ours is not that much less",
    )
    v = _judge(ratio, {"x_m": 0.1}, d=_run({"x_m": 0.4}))
    assert v.verdict == AGREES and v.value == pytest.approx(0.25)
    assert (v.numerator, v.denominator) == (pytest.approx(0.1), pytest.approx(0.4))
    assert _judge(ratio, {"x_m": 0.35}, d=_run({"x_m": 0.4})).verdict == DIFFERS  # 0.875: less, not by 20 %
    assert _judge(ratio, {"x_m": None}, d=_run({"x_m": 0.4})).verdict == DIFFERS
    assert _judge(ratio, {"x_m": 0.1}).verdict == NOT_RUN  # the denominator's run is not bundled
    failed = _judge(ratio, {"x_m": 0.1}, d=_run({"x_m": 0.4}, status="diverged"))
    assert failed.verdict == FAILED and failed.status == "diverged"
    same_run = _claim(ratio_key="y_m", bound=2.0, compare="min", criterion_why="w")
    assert _judge(same_run, {"x_m": 3.0, "y_m": 1.0}).value == pytest.approx(3.0)
    with pytest.raises(MissingKey, match="'y_m' is not in the summary of run 'r'"):
        _judge(same_run, {"x_m": 3.0})


def test_claim_validation_names_the_problem():
    with pytest.raises(ValueError, match="exactly one of paper_value, paper_range, bound, expect"):
        _claim()
    with pytest.raises(ValueError, match="exactly one of"):
        _claim(paper_value=1.0, bound=1.0, tolerance_why="w", criterion_why="w")
    with pytest.raises(ValueError, match="tolerance_why"):
        _claim(paper_value=1.0)
    with pytest.raises(ValueError, match="paper_says states no number"):
        _claim(paper_value=1.0, tolerance_why="w", paper_says="it is small")
    with pytest.raises(ValueError, match="criterion_why"):
        _claim(bound=1.0, compare="max")
    with pytest.raises(ValueError, match="low, high"):
        _claim(paper_range=(2.0, 1.0), tolerance_why="w")
    with pytest.raises(ValueError, match="no ratio_key, no tolerance"):
        _claim(expect="collapsed", criterion_why="w", ratio_key="k")
    with pytest.raises(ValueError, match="ratio_run names the run of ratio_key"):
        _claim(bound=1.0, compare="max", criterion_why="w", ratio_run="d")
    with pytest.raises(ValueError, match="title"):
        _claim(bound=1.0, compare="max", criterion_why="w", title="x" * 200)


def test_paper_refuses_a_ratio_over_an_unknown_run():
    claim = _claim(bound=1.0, compare="max", criterion_why="w", ratio_key="x_m", ratio_run="missing")
    with pytest.raises(ValueError, match="ratio_run 'missing' is not one of the"):
        Paper(
            paper="p",
            title="t",
            citation="c",
            bib_label="b",
            sweep="s",
            run=({"id": "r", "config": CONFIG},),
            claim=[claim],
        )


# --------------------------------------------------------------------------- registry


def test_every_shipped_claims_file_loads_and_names_existing_configs():
    papers = load_registry()
    assert set(papers) == {"cnusail", "current_loops", "msac", "reflector", "truss"}
    for paper in papers.values():
        assert (ROOT / paper.sweep).is_file(), paper.sweep
        assert paper.claim, paper.paper
        for spec in paper.run:
            assert (ROOT / spec.config).is_file(), spec.config
        for claim in paper.claim:
            assert (claim.tolerance_why if claim.numeric else claim.criterion_why).strip(), claim.id


def test_every_reproduction_sweep_lists_the_registry_runs():
    """Each paper's sweep runs exactly its registry runs, with the same configs and overrides."""
    for paper in load_registry().values():
        sweep = {r.id: r for r in load_sweep(ROOT / paper.sweep).runs}
        assert set(sweep) == {r.id for r in paper.run}, paper.sweep
        for spec in paper.run:
            assert sweep[spec.id].config.resolve() == (ROOT / spec.config).resolve(), spec.id
            assert tuple(sweep[spec.id].overrides) == spec.set, spec.id
            assert not sweep[spec.id].problem, (spec.id, sweep[spec.id].problem)


def test_registry_refuses_a_claim_on_an_unknown_run(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(
        'paper = "bad"\ntitle = "t"\ncitation = "c"\nbib_label = "b"\nsweep = "s"\n'
        '[[run]]\nid = "r"\nconfig = "x.toml"\n'
        '[[claim]]\nid = "c"\ntitle = "t"\npaper_ref = "p"\npaper_says = "s"\nquantity = "q"\n'
        'run = "other"\nkey = "k"\nbound = 1.0\ncompare = "max"\ncriterion_why = "w"\n'
    )
    with pytest.raises(RegistryError, match="bad.toml.*'other'"):
        load_paper(path)


# --------------------------------------------------------------------------- collect


def _paper(**run_kw) -> Paper:
    run = dict(id="lumped", config=CONFIG, figures=["big.png", "absent.png"]) | run_kw
    claim = dict(id="eq6", title="t", paper_ref="Eq. (6)", paper_says="Eq. (6)", quantity="q", run="lumped", key="d")
    claim |= dict(paper_value=0.0, tolerance=0.005, tolerance_why="w")
    return Paper(paper="msac", title="t", citation="c", bib_label="b", sweep="s", run=[run], claim=[claim])


def _fake_run(folder: Path, *, status: str = "completed", overrides: tuple[str, ...] = (), d: float = 1e-3) -> Path:
    """A run folder as the runner writes it (manifest, summary, one large noisy figure)."""
    cfg = load_config(ROOT / CONFIG, list(overrides))
    folder.mkdir(parents=True)
    manifest = {
        "concept": "msac",
        "scenario": cfg.scenario,
        "config": cfg.model_dump(mode="json"),
        "config_hash": config_hash(cfg),
        "numbers_hash": numbers_hash(cfg),
        "created_utc": "2026-01-01T00:00:00+00:00",
        "status": status,
        "t_end_s": 0.02,
        "wall_time_s": 1.0,
        "versions": {"magsail_mj": "0", "mujoco": "4", "numpy": "2", "python": "3", "scipy": "1"},
    }
    (folder / "manifest.json").write_text(json.dumps(manifest))
    (folder / "summary.json").write_text(json.dumps({"status": status, "d": d, "z": 1}))
    ramp = np.linspace(0, 255, 1600, dtype=np.uint8)
    Image.fromarray(np.broadcast_to(ramp[None, :, None], (200, 1600, 3)).copy()).save(folder / "big.png")
    manifest["files"] = {name: file_sha256(folder / name) for name in ("summary.json", "big.png")}
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return folder


def test_figures_are_brought_under_the_byte_budget(tmp_path):
    rng = np.random.default_rng(0)
    Image.fromarray(rng.integers(0, 255, (700, 1100, 3), dtype=np.uint8)).save(tmp_path / "noise.png")
    assert (tmp_path / "noise.png").stat().st_size > 2 * FIGURE_MAX_BYTES
    data = bundle_mod.downscale_png(tmp_path / "noise.png")
    assert len(data) <= FIGURE_MAX_BYTES
    (tmp_path / "small.png").write_bytes(data)
    assert max(Image.open(tmp_path / "small.png").size) <= bundle_mod.FIGURE_MAX_PX // 2  # halved once
    with pytest.raises(BundleError, match="noise.png: cannot be brought under 100 bytes"):
        bundle_mod.downscale_png(tmp_path / "noise.png", max_bytes=100)


def test_collect_copies_summary_identity_and_downscaled_figures(tmp_path):
    run = _fake_run(tmp_path / "run")
    out = collect([run], tmp_path / "results", {"msac": _paper()})
    dest = tmp_path / "results" / "msac" / "lumped"
    assert out == [dest]
    assert sorted(p.name for p in dest.iterdir()) == ["big.png", "identity.json", "summary.json"]
    assert (dest / "big.png").stat().st_size <= FIGURE_MAX_BYTES
    assert max(Image.open(dest / "big.png").size) <= bundle_mod.FIGURE_MAX_PX
    ident = json.loads((dest / "identity.json").read_text())
    assert ident["registry_config"] == CONFIG and ident["status"] == "completed"
    assert set(ident["versions"]) == {"magsail_mj", "mujoco", "numpy", "python"}
    index = json.loads((tmp_path / "results" / "index.json").read_text())
    assert index["msac"]["lumped"]["files"] == ["big.png", "identity.json", "summary.json"]
    data = read_bundle(tmp_path / "results")
    assert data["msac"]["lumped"]["summary"]["d"] == 1e-3


def test_collect_is_deterministic(tmp_path):
    run = _fake_run(tmp_path / "run")
    for name in ("a", "b"):
        collect([run], tmp_path / name, {"msac": _paper()})
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files
    for rel in files:
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel
    text = (tmp_path / "a" / "msac" / "lumped" / "summary.json").read_text()
    assert list(json.loads(text)) == sorted(json.loads(text))


def test_collect_refuses_missing_files_naming_the_folder(tmp_path):
    run = _fake_run(tmp_path / "run")
    (run / "summary.json").unlink()
    with pytest.raises(BundleError, match=r"run: not a finished run folder \(summary.json is missing"):
        collect([run], tmp_path / "results", {"msac": _paper()})
    with pytest.raises(BundleError, match="manifest.json is missing"):
        collect([tmp_path], tmp_path / "results", {"msac": _paper()})
    assert not (tmp_path / "results").exists()  # nothing written before every folder is checked


def test_collect_refuses_another_config_or_a_pinned_hash(tmp_path):
    other = _fake_run(tmp_path / "other", overrides=("sim.timestep_s=1e-5",))
    with pytest.raises(BundleError, match="other: its config matches no registry run.*sim.timestep_s"):
        collect([other], tmp_path / "results", {"msac": _paper()})
    run = _fake_run(tmp_path / "run")
    with pytest.raises(BundleError, match="config_hash .* is not the registry's 0123"):
        collect([run], tmp_path / "results", {"msac": _paper(config_hash="0123")})
    pinned = config_hash(load_config(ROOT / CONFIG))
    assert collect([run], tmp_path / "results", {"msac": _paper(config_hash=pinned)})


def test_collect_ignores_presentation_keys_and_new_schema_keys(tmp_path):
    run = _fake_run(tmp_path / "run", overrides=("sim.progress=false",))
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["config"]["sim"].pop("record_every")  # a key the run's schema did not have yet
    (run / "manifest.json").write_text(json.dumps(manifest))
    collect([run], tmp_path / "results", {"msac": _paper()})
    ident = json.loads((tmp_path / "results" / "msac" / "lumped" / "identity.json").read_text())
    assert ident["config_keys_not_compared"] == ["sim.record_every"]


def test_collect_keeps_the_bundle_under_its_budget(tmp_path, monkeypatch):
    run = _fake_run(tmp_path / "run")
    monkeypatch.setattr(bundle_mod, "BUNDLE_MAX_BYTES", 1000)
    with pytest.raises(BundleError, match="above the bundle budget of 1000 bytes"):
        collect([run], tmp_path / "results", {"msac": _paper()})


def test_a_sweep_folder_stands_for_its_runs(tmp_path):
    sweep = tmp_path / "sweep"
    _fake_run(sweep / "lumped")
    (sweep / "sweep_manifest.json").write_text("{}")
    assert collect([sweep], tmp_path / "results", {"msac": _paper()}) == [tmp_path / "results" / "msac" / "lumped"]


# --------------------------------------------------------------------------- render


def test_render_covers_every_registered_claim_and_counts_not_run():
    papers = load_registry()
    pages = render_pages(papers, ROOT / "no_such_bundle", PAGES)
    assert set(pages) == {PAGES / f"{p}.md" for p in papers} | {PAGES / "index.md"}
    for paper in papers.values():
        text = pages[PAGES / f"{paper.paper}.md"]
        for claim in paper.claim:
            assert f"`{claim.id}`" in text and claim.key in text
        n = len(paper.claim)
        assert f"{n} claims: 0 differs · 0 failed · {n} not run · 0 agrees" in text
        assert f"magsail sweep {paper.sweep}" in text
    assert all(f"<{p}>`" in pages[PAGES / "index.md"] for p in papers)


def test_render_shows_verdict_tolerance_explanation_and_figure(tmp_path):
    run = _fake_run(tmp_path / "run", d=0.02)
    paper = _paper()
    claim = paper.claim[0].model_copy(update={"explanation": "the lumped model drops the bus", "figure": "big.png"})
    paper = paper.model_copy(update={"claim": (claim,)})
    collect([run], tmp_path / "results", {"msac": paper})
    text = render_pages({"msac": paper}, tmp_path / "results", tmp_path / "docs")[tmp_path / "docs" / "msac.md"]
    assert "1 claims: 1 differs" in text
    assert "  - 0.02\n" in text and "± 0.005" in text and "the lumped model drops the bus" in text
    assert "```{figure} ../results/msac/lumped/big.png" in text
    assert "2026-01-01T00:00:00" in text


def test_render_refuses_a_differing_claim_without_explanation(tmp_path):
    run = _fake_run(tmp_path / "run", d=0.02)
    collect([run], tmp_path / "results", {"msac": _paper()})
    with pytest.raises(MissingExplanation, match="'eq6'"):
        render_pages({"msac": _paper()}, tmp_path / "results", tmp_path / "docs")


# --------------------------------------------------------------------------- the committed bundle and pages


def test_committed_bundle_keys_exist_and_budget_holds():
    papers = load_registry()
    data = read_bundle(RESULTS)
    assert data, "the committed bundle results/ is empty"
    assert bundle_bytes(RESULTS) <= BUNDLE_MAX_BYTES
    for png in RESULTS.rglob("*.png"):
        assert png.stat().st_size <= FIGURE_MAX_BYTES, png
    for paper_id, runs in data.items():
        paper = papers[paper_id]
        for run_id in runs:
            paper.run_spec(run_id)  # every bundled run is a registry run
        for claim in paper.claim:
            for run_id, key in ((claim.run, claim.key), (claim.denominator_run, claim.ratio_key or claim.key)):
                run = runs.get(run_id)
                if run is not None:  # a structurally failed run's summary holds its keys as well
                    assert key in run["summary"], (paper_id, claim.id, run_id, key)
    index = json.loads((RESULTS / "index.json").read_text())
    assert {p: sorted(r) for p, r in index.items()} == {p: sorted(r) for p, r in data.items()}


def test_committed_pages_are_the_render_of_the_committed_bundle():
    pages = render_pages(load_registry(), RESULTS, PAGES)
    for path, text in pages.items():
        assert path.read_text(encoding="utf-8") == text, f"{path} is stale: run magsail report render"


def test_docs_link_the_reproduction_pages():
    index = (ROOT / "docs" / "index.md").read_text()
    assert "reproduction/index" in index
    built = ROOT / "docs" / "_build" / "html"
    if (built / "reproduction" / "index.html").is_file():  # after scripts/build_docs.sh
        for paper in load_registry():
            assert (built / "reproduction" / f"{paper}.html").is_file(), paper


# --------------------------------------------------------------------------- command line


@pytest.mark.parametrize("action", ["collect", "render", "update", "sweep"])
def test_report_actions_have_help(action, capsys):
    assert cli.main(["report", action, "--help"]) == 0
    out = capsys.readouterr().out
    assert "usage: magsail report " + action in out
    for line in re.findall(r"^\s+(--[a-z-]+|RUN_DIR|SWEEP_DIR)\b.*$", out, flags=re.M):
        assert line  # every listed argument comes with text (argparse prints it on the same or next line)


def test_report_help_lists_the_actions(capsys):
    assert cli.main(["report", "--help"]) == 0
    out = capsys.readouterr().out
    assert all(a in out for a in ("collect", "render", "update", "sweep"))


def test_report_collect_exit_2_names_the_folder(tmp_path, capsys):
    assert cli.main(["report", "collect", str(tmp_path), "--bundle", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and str(tmp_path) in err and "manifest.json is missing" in err
    assert "Traceback" not in err


def test_report_without_action_routes_run_folders_to_update_and_others_to_sweep(tmp_path, capsys):
    run = _fake_run(tmp_path / "run", overrides=("sim.timestep_s=1e-5",))  # a run folder of no registry run
    assert cli.main(["report", str(run), "--bundle", str(tmp_path / "b"), "--out", str(tmp_path / "d")]) == 2
    assert "matches no registry run" in capsys.readouterr().err
    assert cli.main(["report", str(tmp_path / "run")]) == 2  # a run folder alone: update as well
    assert "matches no registry run" in capsys.readouterr().err
    assert cli.main(["report", str(tmp_path)]) == 2  # not a run folder: the sweep report refuses it
    assert "matches no registry run" not in capsys.readouterr().err


def test_report_render_refuses_a_missing_bundle(tmp_path, capsys):
    assert cli.main(["report", "render", "--bundle", str(tmp_path / "none"), "--out", str(tmp_path / "d")]) == 2
    assert "--bundle" in capsys.readouterr().err


def test_report_render_writes_the_pages(tmp_path, capsys):
    run = _fake_run(tmp_path / "run")
    collect([run], tmp_path / "b", {"msac": _paper()})
    assert cli.main(["report", "render", "--bundle", str(tmp_path / "b"), "--out", str(tmp_path / "d")]) == 0
    pages = json.loads(capsys.readouterr().out)["pages"]
    assert {Path(p).name for p in pages} == {f"{p}.md" for p in load_registry()} | {"index.md"}


def test_report_update_collects_and_renders_a_registry_run(tmp_path, capsys):
    """``magsail report RUN_DIR --bundle B --out D`` with a run of the real registry (the MSAC lumped
    limit): the bundle gets the run, the MSAC page its verdict; a missing claim key refuses (exit 2)."""
    run = _fake_run(tmp_path / "run")
    args = [str(run), "--bundle", str(tmp_path / "b"), "--out", str(tmp_path / "d")]
    assert cli.main(["report", *args]) == 2  # the summary lacks the claim's key
    assert "mujoco_vs_eq6_rel_diff" in capsys.readouterr().err
    summary = json.loads((run / "summary.json").read_text()) | {"mujoco_vs_eq6_rel_diff": -0.0025}
    (run / "summary.json").write_text(json.dumps(summary))
    manifest = json.loads((run / "manifest.json").read_text())  # as if the run had written it so
    manifest["files"]["summary.json"] = file_sha256(run / "summary.json")
    (run / "manifest.json").write_text(json.dumps(manifest))
    assert cli.main(["report", *args]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["runs"] == [str(tmp_path / "b" / "msac" / "lumped_limit")]
    text = (tmp_path / "d" / "msac.md").read_text()
    assert "(repro-msac-eq6-lumped-limit)=" in text and "  - -0.0025\n" in text and "**agrees**" in text
