"""The MJCF committed next to every config equals what the builder generates now."""

from __future__ import annotations

import sys

import pytest

from tests.conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
from build_models import generated_xml  # noqa: E402

from magsail_mj.sweep import is_sweep_file  # noqa: E402

CONFIGS = sorted(p for p in (REPO / "models").rglob("*.toml") if not is_sweep_file(p))


@pytest.mark.parametrize("config", CONFIGS, ids=lambda p: str(p.relative_to(REPO / "models")))
def test_committed_mjcf_is_current(config):
    xml = config.with_suffix(".xml")
    assert xml.exists(), f"{xml} is missing: run python scripts/build_models.py"
    assert xml.read_text() == generated_xml(config), (
        f"{xml} differs from the generated MJCF: run python scripts/build_models.py")


def test_build_cli_prints_model_size(tmp_path, capsys):
    import json

    from magsail_mj.cli import main

    out = tmp_path / "m.xml"
    rc = main(["build", str(REPO / "models/truss_magnetorquer/dist_vs_central/case_a_central_bangbang.toml"),
               "-o", str(out)])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert (info["nodes"], info["struts"], info["dofs"]) == (800, 3402, 2400)
    import mujoco
    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.ntendon == 3402 and model.nbody == 801
    assert model.opt.gravity.tolist() == [0.0, 0.0, 0.0]
