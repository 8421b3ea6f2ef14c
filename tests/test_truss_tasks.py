"""Truss concept layout: one task class per scenario kind, registered by name; no import cycle.

Checks (each can fail): the registered kinds are exactly the schema's ``scenario`` values; a
config of every kind builds its own class; the concept's modules import each other in one
direction only (a DAG), with every import at module top and none under ``TYPE_CHECKING``;
metrics and plots modules import no task module; the orbital metrics work on plain arrays
(an exponential decay of the rates against its analytic threshold time).
"""

from __future__ import annotations

import ast
import typing
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.concepts import task_kinds
from magsail_mj.config import load_config
from magsail_mj.scenario import build_scenario
from magsail_mj.concepts.truss_magnetorquer import tasks as tt
from magsail_mj.concepts.truss_magnetorquer.config import TrussConfig
from magsail_mj.concepts.truss_magnetorquer.orbital import detumble_keys
from tests.conftest import REPO

SCEN = REPO / "magsail_mj" / "scenarios"
TRUSS_MODULES = ("truss", "truss_config", "truss_model", "truss_tasks", "truss_metrics", "truss_orbital",
                 "truss_plots")
KIND_CONFIGS = {
    "cantilever": ("magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml", tt.CantileverTask),
    "free": ("magsail_mj/concepts/truss_magnetorquer/configs/libration.toml", tt.FreeTask),
    "dist_vs_central": ("magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml",
                        tt.DistVsCentralTask),
    "detumble": ("magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", tt.DetumbleTask),
    "slew": ("magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml", tt.SlewTask),
}


def module_imports(path: Path) -> tuple[set[str], list[str]]:
    """``(magsail_mj modules imported at module top, problems)``: an import inside a function or
    class, or under ``if TYPE_CHECKING``, is a problem (named with its line)."""
    tree = ast.parse(path.read_text())
    top: set[str] = set()
    problems: list[str] = []
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module:
            top.add(node.module)
        elif isinstance(node, ast.Import):
            top.update(a.name for a in node.names)
        elif isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            problems.append(f"{path.name}:{node.lineno}: TYPE_CHECKING block")
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            for inner in ast.walk(node):
                if isinstance(inner, (ast.Import, ast.ImportFrom)):
                    problems.append(f"{path.name}:{inner.lineno}: import inside {node.name}")
    return top, problems


def concept_graph(modules: tuple[str, ...]) -> tuple[dict[str, set[str]], list[str]]:
    """Import edges among ``modules`` (names under magsail_mj.scenario) and the problems found."""
    graph: dict[str, set[str]] = {}
    problems: list[str] = []
    for name in modules:
        top, bad = module_imports(SCEN / f"{name}.py")
        problems += bad
        graph[name] = {m.rpartition(".")[2] for m in top if m.startswith("magsail_mj.scenario.")} & set(modules)
    return graph, problems


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A cycle of ``graph`` as a list of nodes, or ``None`` (depth-first search)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in state and (found := visit(m)):
                return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state and (found := visit(n)):
            return found
    return None


def test_cycle_finder_sees_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_registered_kinds_are_the_schema_scenarios():
    kinds = typing.get_args(TrussConfig.model_fields["scenario"].annotation)
    assert sorted(kinds) == task_kinds("truss_magnetorquer")


@pytest.mark.parametrize("kind", sorted(KIND_CONFIGS))
def test_every_kind_builds_its_own_class(kind):
    path, cls = KIND_CONFIGS[kind]
    cfg = load_config(REPO / path, ["lattice.units=3", "sim.duration_s=2"])
    assert cfg.scenario == kind
    sc = build_scenario(cfg)
    assert type(sc) is cls and isinstance(sc, tt.TrussScenario)
    assert sc.render_info()["overlay"] == list(cls.OVERLAY)


def test_truss_modules_form_a_dag_with_imports_at_top():
    graph, problems = concept_graph(TRUSS_MODULES)
    assert not problems, problems
    assert find_cycle(graph) is None, find_cycle(graph)
    for name in ("truss_metrics", "truss_orbital", "truss_plots", "truss_model", "truss_config"):
        assert not graph[name] & {"truss", "truss_tasks"}, (name, graph[name])


def test_detumble_keys_of_an_exponential_decay():
    """Rates ω_i(t) = ω0_i e^{−t/τ}: all three fall below 1e-3 rad/s at t* = τ ln(max|ω0| / 1e-3)
    (first sample at or after t*, so within one sample of 1 s) and stay there; H0 = |I ω0|."""
    tau = 300.0
    t = np.arange(0.0, 3000.0, 1.0)
    w0 = np.array([0.02, -0.01, 0.005])
    omega = w0[None, :] * np.exp(-t / tau)[:, None]
    inertia = np.diag([2.0e6, 3.0e6, 4.0e6])
    keys = detumble_keys(t, omega, inertia_kgm2=inertia, omega0_body=w0)
    t_star = tau * np.log(0.02 / 1e-3)
    assert t_star <= keys["t_rates_below_threshold_first_s"] < t_star + 1.0
    assert keys["t_rates_below_threshold_stay_s"] == keys["t_rates_below_threshold_first_s"]
    assert keys["H0_Nms"] == pytest.approx(np.linalg.norm(inertia @ w0), rel=1e-12)
    assert keys["omega_norm_max_rad_s"] == pytest.approx(np.linalg.norm(w0), rel=1e-12)
    np.testing.assert_allclose(keys["omega_final_rad_s"], w0 * np.exp(-t[-1] / tau), rtol=1e-12)
