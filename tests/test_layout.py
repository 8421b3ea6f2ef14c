"""Package layout rules, from the AST of every module of magsail_mj (no module is imported).

The import graph has one edge per import statement naming a magsail_mj module, wherever the
statement is (module top, function body, ``if TYPE_CHECKING:``). Rules:

- no cycle (a failure prints one cycle as a path of module names);
- no import inside a function or method, except the optional heavy dependencies in
  :data:`ENTRY_POINT_IMPORTS` at their single entry point;
- framework and shared modules (everything outside ``magsail_mj.concepts.<concept>``) never
  import a concept package; concept packages never import each other;
- every concept package has ``__init__``, ``config``, ``model``, ``tasks``, ``metrics``,
  ``plots``, ``README.md`` and ``configs/``;
- a new concept package is discovered and registered by :mod:`magsail_mj.concepts` with no
  edit elsewhere.
"""

from __future__ import annotations

import ast
import sys
import typing
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import magsail_mj
import magsail_mj.concepts as registry

PACKAGE_DIR = Path(magsail_mj.__file__).resolve().parent
CONCEPTS = "magsail_mj.concepts"
CONCEPT_FILES = ("__init__.py", "config.py", "model.py", "tasks.py", "metrics.py", "plots.py", "README.md")

ENTRY_POINT_IMPORTS: dict[str, set[str]] = {
    # module → top-level names it may import inside a function (optional or GL-bound dependencies)
    "magsail_mj.environment.atmosphere": {"pymsis"},
    "magsail_mj.render.backend": {"mujoco", "OpenGL"},
    "magsail_mj.sweep": {"dask_jobqueue"},
    "magsail_mj.sweep.cluster": {"dask_jobqueue"},
    "magsail_mj.entry": {"magsail_mj.cli"},
    "magsail_mj": {"magsail_mj.api"},
}
"""Allowed in-function imports (exact module, or a top-level package name). ``render.backend``
picks the GL backend before MuJoCo loads it; ``entry`` imports the CLI after installing its
signal handlers (a signal during the imports ends the command with 130); the package loads
``magsail_mj.load`` on first use (PEP 562) so that ``import magsail_mj`` stays light."""


@dataclass
class Module:
    name: str
    path: Path
    imports: list[tuple[int, str, bool]] = field(default_factory=list)
    """(line, imported magsail_mj module or top-level package name, inside a function)."""


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(name: str, known: set[str]) -> str:
    """The longest existing module prefix of a dotted magsail_mj name."""
    while name and name not in known:
        name = name.rpartition(".")[0]
    return name


def _targets(node: ast.Import | ast.ImportFrom, mod: Module, known: set[str]) -> list[str]:
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:
            pkg = mod.name.split(".") if mod.path.name == "__init__.py" else mod.name.split(".")[:-1]
            pkg = pkg[: len(pkg) - node.level + 1]
            base = ".".join(pkg + ([base] if base else []))
        names = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
    out = []
    for n in names:
        if n == "magsail_mj" or n.startswith("magsail_mj."):
            n = _resolve(n, known)
        else:
            n = n.split(".")[0]
        if n and n != mod.name:
            out.append(n)
    return out


def _collect() -> dict[str, Module]:
    mods = {_module_name(p): Module(_module_name(p), p) for p in sorted(PACKAGE_DIR.rglob("*.py"))}
    known = set(mods)
    for mod in mods.values():
        tree = ast.parse(mod.path.read_text(encoding="utf-8"), filename=str(mod.path))

        def visit(node: ast.AST, in_function: bool, mod: Module = mod) -> None:
            for child in ast.iter_child_nodes(node):
                inner = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
                if isinstance(child, (ast.Import, ast.ImportFrom)):
                    mod.imports += [(child.lineno, t, in_function) for t in _targets(child, mod, known)]
                visit(child, inner)

        visit(tree, False)
    return mods


MODULES = _collect()
GRAPH = {m.name: sorted({t for _, t, _ in m.imports if t in MODULES}) for m in MODULES.values()}


def concept_of(module: str) -> str | None:
    """The concept package a module belongs to (``None``: framework or shared)."""
    if module.startswith(CONCEPTS + "."):
        return module.split(".")[2]
    return None


CONCEPT_NAMES = (
    sorted(p.name for p in (PACKAGE_DIR / "concepts").iterdir() if (p / "__init__.py").is_file())
    if (PACKAGE_DIR / "concepts").is_dir()
    else []
)


def find_cycle(graph: dict[str, list[str]]) -> list[str] | None:
    """One cycle of ``graph`` as ``[a, b, ..., a]``, or ``None`` (iterative depth-first search)."""
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    for root in graph:
        if root in state:
            continue
        stack = [(root, iter(graph[root]))]
        path = [root]
        state[root] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                state[node] = 2
                stack.pop()
                path.pop()
            elif state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            elif nxt not in state:
                state[nxt] = 1
                stack.append((nxt, iter(graph[nxt])))
                path.append(nxt)
    return None


def test_find_cycle_finds_a_planted_cycle_and_accepts_a_dag():
    assert find_cycle({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": ["b", "c"], "b": ["c"], "c": []}) is None


def test_the_graph_sees_every_module_and_import_kind():
    """Sanity of the AST scan: the package, a function-level import and TYPE_CHECKING blocks count."""
    assert "magsail_mj.concepts" in MODULES and "magsail_mj.config" in MODULES
    assert "magsail_mj.concepts" in GRAPH["magsail_mj.config"]
    assert any(inner for m in MODULES.values() for _, _, inner in m.imports)  # pymsis at its entry point
    assert len(MODULES) > 50


def test_no_import_cycle():
    cycle = find_cycle(GRAPH)
    assert cycle is None, "import cycle: " + " → ".join(cycle or [])


def _params(names: list[str], pending: dict[str, str]) -> list:
    """``names`` as test parameters, those in ``pending`` marked as expected (non-strict) failures."""
    return [
        pytest.param(n, marks=pytest.mark.xfail(reason=pending[n], strict=False)) if n in pending else n for n in names
    ]


PENDING_IN_FUNCTION: dict[str, str] = {}
"""Modules of this layout that still import inside functions (cleaned by their owners; each
entry is an expected failure until then, and is removed once its module passes)."""


@pytest.mark.parametrize("name", _params(sorted(MODULES), PENDING_IN_FUNCTION))
def test_imports_at_module_top(name):
    mod = MODULES[name]
    allowed = ENTRY_POINT_IMPORTS.get(name, set())
    inner = [
        f"{mod.path.relative_to(PACKAGE_DIR.parent)}:{line}: {target}"
        for line, target, in_function in mod.imports
        if in_function and target.split(".")[0] not in allowed and target not in allowed
    ]
    assert not inner, "imports inside functions:\n" + "\n".join(inner)


PENDING_CONCEPT_IMPORTS: dict[str, str] = {}
"""Framework modules that still import concept modules (expected failures until their owners switch
to discovery; an entry is removed once its module passes)."""


@pytest.mark.parametrize(
    "name", _params([n for n in sorted(GRAPH) if concept_of(n) is None and GRAPH[n]], PENDING_CONCEPT_IMPORTS)
)
def test_framework_and_shared_modules_import_no_concept(name):
    bad = [t for t in GRAPH[name] if concept_of(t) is not None]
    assert not bad, f"{name} (framework/shared) imports concept modules: {bad}"


@pytest.mark.parametrize("concept", CONCEPT_NAMES)
def test_concepts_import_no_other_concept(concept):
    bad = [
        f"{m} → {t}"
        for m, targets in GRAPH.items()
        if concept_of(m) == concept
        for t in targets
        if concept_of(t) not in (None, concept)
    ]
    assert not bad, f"{concept} imports another concept:\n" + "\n".join(bad)


@pytest.mark.parametrize("concept", CONCEPT_NAMES)
def test_concept_package_is_complete(concept):
    pkg = PACKAGE_DIR / "concepts" / concept
    missing = [f for f in CONCEPT_FILES if not (pkg / f).is_file()]
    if not (pkg / "configs").is_dir() or not any((pkg / "configs").rglob("*.toml")):
        missing.append("configs/ (with TOML files)")
    assert not missing, f"{concept}: missing {missing}"


@pytest.mark.parametrize("concept", CONCEPT_NAMES)
def test_concept_registers_its_schema_and_tasks(concept):
    """Discovery finds the package; it registers its config schema and at least one task or builder."""
    assert concept in registry.config_schemas()
    assert registry.task_kinds(concept) or concept in registry.BUILDERS
    assert registry.concept_modules("tasks")[concept].__name__ == f"{CONCEPTS}.{concept}.tasks"


@pytest.mark.parametrize("concept", CONCEPT_NAMES)
def test_registered_task_kinds_are_the_schema_kinds(concept):
    """Every value of the config's kind field (a ``Literal``) has its task class, and no other
    kind is registered (a concept with a builder instead serves every kind itself)."""
    if concept in registry.BUILDERS:
        pytest.skip(f"{concept} builds its tasks with a builder")
    schema = registry.config_schemas()[concept]
    kinds = typing.get_args(schema.model_fields[registry.KIND_KEYS[concept]].annotation)
    assert kinds and sorted(kinds) == registry.task_kinds(concept)


def test_a_new_concept_package_is_discovered_without_editing_anything(tmp_path, monkeypatch):
    """Adding a package under magsail_mj.concepts is enough: discovery imports and registers it."""
    pkg = tmp_path / "zz_layout_demo"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from magsail_mj.concepts import register_config, register_task\n\n\n"
        "@register_config('zz_layout_demo', kind_key='kind')\n"
        "class DemoConfig:\n"
        "    concept = 'zz_layout_demo'\n"
        "    kind = 'spin'\n\n\n"
        "@register_task('zz_layout_demo', 'spin')\n"
        "class SpinTask:\n"
        "    def __init__(self, cfg):\n"
        "        self.cfg = cfg\n",
        encoding="utf-8",
    )
    (pkg / "extra.py").write_text("VALUE = 7\n", encoding="utf-8")
    monkeypatch.setattr(registry, "__path__", [*registry.__path__, str(tmp_path)])
    monkeypatch.setattr(registry, "_discovered", False)
    monkeypatch.setattr(registry, "_schemas_discovered", False)
    for table in ("CONFIG_SCHEMAS", "KIND_KEYS", "TASKS"):  # registrations vanish with the test
        monkeypatch.setattr(registry, table, dict(getattr(registry, table)))
    try:
        schemas = registry.config_schemas()
        assert "zz_layout_demo" in schemas
        assert registry.task_kinds("zz_layout_demo") == ["spin"]
        cfg = schemas["zz_layout_demo"]()
        task = registry.build_task(cfg)
        assert type(task).__name__ == "SpinTask" and task.cfg is cfg
        extra = registry.concept_modules("extra")
        assert list(extra) == ["zz_layout_demo"] and extra["zz_layout_demo"].VALUE == 7
        cfg.kind = "tumble"
        with pytest.raises(ValueError, match=r"^kind: no zz_layout_demo task 'tumble'; known \['spin'\]"):
            registry.build_task(cfg)
    finally:
        for name in ("magsail_mj.concepts.zz_layout_demo.extra", "magsail_mj.concepts.zz_layout_demo"):
            sys.modules.pop(name, None)


def test_registry_rejects_bad_names_and_unknown_concepts():
    with pytest.raises(ValueError, match="^concept: "):
        registry.register_task("not a name", "x")
    with pytest.raises(ValueError, match="^kind: "):
        registry.register_task("c", "")

    class Cfg:
        concept = "zz_no_such_concept"
        scenario = "x"

    with pytest.raises(ValueError, match="^concept: no scenario builder for 'zz_no_such_concept'"):
        registry.build_task(Cfg())
