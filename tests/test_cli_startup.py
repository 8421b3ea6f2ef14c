"""``magsail`` starts at once: the parser imports no heavy module, a verb loads only its own.

Each case starts ``python -m magsail_mj`` as a user does and reads, from inside the process, the
modules it imported (a ``sys.modules`` dump at exit); no wall time is asserted (the benchmark
``scripts/bench_startup.py`` prints the times).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import magsail_mj
from magsail_mj import cli, resources

ROOT = Path(__file__).resolve().parents[1]
CONFIG = str(ROOT / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")
HEAVY = ("dask", "distributed", "matplotlib", "mediapy", "mujoco", "numpy", "pydantic", "scipy", "xarray", "zarr")

# runs the command in-process after registering an exit hook that prints the top-level packages imported
_PROBE = """
import atexit, json, sys
atexit.register(lambda: print("MODULES " + json.dumps(sorted({m.split('.')[0] for m in sys.modules})), file=sys.stderr))
from magsail_mj.entry import main
sys.argv = ["magsail", *sys.argv[1:]]
sys.exit(main())
"""


def _imported(*argv: str) -> tuple[int, set[str], str]:
    proc = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, cwd=ROOT, timeout=300)
    line = next((x for x in proc.stderr.splitlines() if x.startswith("MODULES ")), None)
    assert line is not None, proc.stderr
    return proc.returncode, set(json.loads(line[len("MODULES ") :])), proc.stdout


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["report", "sweep", "--help"]])
def test_help_and_version_import_no_heavy_module(argv):
    code, modules, out = _imported(*argv)
    assert code == 0 and out.strip()
    assert not modules & set(HEAVY), sorted(modules & set(HEAVY))


def test_usage_error_imports_no_heavy_module():
    code, modules, _ = _imported("run", CONFIG)  # --out missing
    assert code == 2
    assert not modules & set(HEAVY), sorted(modules & set(HEAVY))


# one config of every concept, validated in one process (the concept registry loads the schemas only)
VALIDATE_CONFIGS = {
    "cnusail": "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
    "current_loops": "magsail_mj/concepts/current_loops/configs/slew.toml",
    "msac": "magsail_mj/concepts/msac/configs/paper_1khz.toml",
    "reflector": "magsail_mj/concepts/reflector/configs/detumble.toml",
    "structure": "magsail_mj/concepts/structure/configs/sail_detumble.toml",
    "truss_magnetorquer": "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml",
}

_VALIDATE_PROBE = """
import json, sys
from magsail_mj.cli import main
codes = [main(["validate", path]) for path in sys.argv[1:]]
print("RESULT " + json.dumps({"codes": codes, "modules": sorted(sys.modules)}), file=sys.stderr)
"""


def test_validate_imports_no_dask_matplotlib_nor_mediapy():
    """``magsail validate`` of a config of every concept: no Dask, Matplotlib or mediapy, no tasks or plots."""
    concepts = sorted(p.name for p in (ROOT / "magsail_mj/concepts").iterdir() if (p / "__init__.py").is_file())
    assert sorted(VALIDATE_CONFIGS) == concepts  # a new concept adds its config here
    paths = [str(ROOT / c) for c in VALIDATE_CONFIGS.values()]
    proc = subprocess.run(
        [sys.executable, "-c", _VALIDATE_PROBE, *paths], capture_output=True, text=True, cwd=ROOT, timeout=300
    )
    line = next((x for x in proc.stderr.splitlines() if x.startswith("RESULT ")), None)
    assert line is not None, proc.stderr
    result = json.loads(line[len("RESULT ") :])
    assert result["codes"] == [0] * len(paths), proc.stderr
    assert proc.stdout.count('"valid": true') == len(paths)
    top = {m.split(".")[0] for m in result["modules"]}
    forbidden = {"dask", "distributed", "matplotlib", "mediapy"}
    assert not top & forbidden, sorted(top & forbidden)
    leaves = [m for m in result["modules"] if m.startswith("magsail_mj.concepts.") and m.endswith((".tasks", ".plots"))]
    assert not leaves, leaves


def test_package_import_is_light():
    probe = "import sys, magsail_mj; print(sorted({m.split('.')[0] for m in sys.modules} & set(sys.argv[1:])))"
    proc = subprocess.run([sys.executable, "-c", probe, *HEAVY], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_subpackages_are_attributes_of_the_package(monkeypatch):
    """``import magsail_mj; magsail_mj.envs.list()`` (the subpackage is imported on first use)."""
    monkeypatch.delattr(magsail_mj, "envs", raising=False)  # as in a fresh process
    assert "cnusail/detumble" in magsail_mj.envs.list()
    with pytest.raises(AttributeError, match="no_such_part"):
        magsail_mj.no_such_part  # noqa: B018


def test_parser_constants_match_the_library():
    """The parser's copies of library names (kept there so that it imports nothing heavy)."""
    from magsail_mj.export import FORMATS
    from magsail_mj.report.commands import DEFAULT_BUNDLE, DEFAULT_OUT

    assert cli.MEMORY_ENV_VAR == resources.ENV_VAR
    assert cli.EXPORT_FORMATS == FORMATS
    assert (cli.DEFAULT_BUNDLE, cli.DEFAULT_PAGES) == (DEFAULT_BUNDLE, DEFAULT_OUT)


def test_every_handler_names_an_existing_function():
    import importlib

    handlers = [v for v in vars(cli).values() if isinstance(v, cli._Handler)]
    assert len(handlers) >= 14
    for handler in handlers:
        assert callable(getattr(importlib.import_module(handler.module), handler.function)), handler


def test_bad_memory_limit_names_the_option(capsys):
    assert cli.main(["--memory-limit", "lots", "validate", CONFIG]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --memory-limit") and "lots" in err
