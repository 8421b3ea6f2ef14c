"""The MJCF committed next to every config equals what the builder generates now."""

from __future__ import annotations

import sys

import pytest

from tests.conftest import REPO

sys.path.insert(0, str(REPO / "scripts"))
from build_models import generated_xml, mjcf_difference  # noqa: E402

from magsail_mj.structure.fileformat import is_structure_file  # noqa: E402
from magsail_mj.sweep import is_sweep_file  # noqa: E402

CONFIGS = sorted(
    p for p in (REPO / "magsail_mj" / "concepts").rglob("*.toml") if not is_sweep_file(p) and not is_structure_file(p)
)


@pytest.mark.parametrize("config", CONFIGS, ids=lambda p: str(p.relative_to(REPO / "magsail_mj" / "concepts")))
def test_committed_mjcf_is_current(config):
    xml = config.with_suffix(".xml")
    assert xml.exists(), f"{xml} is missing: run python scripts/build_models.py"
    difference = mjcf_difference(xml.read_text(), generated_xml(config))
    assert difference is None, (
        f"{xml} differs from the generated MJCF ({difference}): run python scripts/build_models.py"
    )


def test_mjcf_comparison_ignores_rounding_noise_only():
    base = '<mujoco><tendon><spatial name="t" stiffness="0.9041597208106965" range="0 1.5"/></tendon></mujoco>'
    noise = base.replace("0.9041597208106965", "0.9041597208106572")
    changed = base.replace("0.9041597208106965", "0.90416")
    assert mjcf_difference(base, noise) is None
    assert "stiffness" in mjcf_difference(base, changed)
    assert "range" in mjcf_difference(base, base.replace("0 1.5", "0 1.6"))
    assert mjcf_difference(base, base.replace('name="t"', 'name="u"')) is not None
    assert mjcf_difference(base, base.replace("<tendon>", "<tendon><spatial/>")) is not None
    # an attribute on one side only: equal when it is round-off of its zero default, else not
    joint = '<mujoco><body><joint name="j" type="slide" stiffness="2.0"/></body></mujoco>'
    assert mjcf_difference(joint, joint.replace('stiffness="2.0"', 'stiffness="2.0" springref="3.5e-15"')) is None
    assert "springref" in mjcf_difference(joint, joint.replace('stiffness="2.0"', 'stiffness="2.0" springref="1e-3"'))
    assert mjcf_difference(joint, joint.replace('type="slide" ', "")) is not None


def test_build_cli_prints_model_size(tmp_path, capsys):
    import json

    from magsail_mj.cli import main

    out = tmp_path / "m.xml"
    rc = main(
        [
            "build",
            str(REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.toml"),  # noqa: E501
            "-o",
            str(out),
        ]
    )
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert (info["nodes"], info["struts"], info["dofs"]) == (800, 3402, 2400)
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(out))
    assert model.ntendon == 3402 and model.nbody == 801
    assert model.opt.gravity.tolist() == [0.0, 0.0, 0.0]
