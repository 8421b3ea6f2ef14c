"""Detumble laws of one's own (:mod:`magsail_mj.control.detumble_plugins`): a law written against the
typed commands runs, unchanged, in a single run, a batch of worlds, the dm_control environment and
a sweep, and is found by name in every process through an installed entry point.

The plug-ins here restate shipped laws through the plug-in door (the B×ω law through the shipped
function, the proportional law from the Ḃ estimate), so a run with the plug-in must equal the run of
the shipped law bit for bit (``np.array_equal``, no tolerance): any input handed over wrongly (a
frame, a stale sample, the wrong rate) changes the numbers.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Mapping

import numpy as np
import pytest

import magsail_mj
from magsail_mj.commands import BodyTorque, MagneticDipole
from magsail_mj.config import ConfigError, load_config
from magsail_mj.control.detumble_laws import bcross_dipole
from magsail_mj.control.detumble_plugins import (
    DetumbleInputs,
    detumble_law_names,
    register_detumble_law,
    unregister_detumble_law,
)
from tests.conftest import REPO
from tests.envs_shared import assert_shipped_policy_gives_the_run_summary
from tests.test_batch_equals_single import assert_same_records, run_and_compare

PRE = REPO / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"


def bcross_plugin(inputs: DetumbleInputs, params: Mapping[str, float]) -> MagneticDipole:
    """The shipped B×ω law ``m = k (ω × B)/‖B‖²`` with ``k = params["gain_Nms"]``."""
    m = bcross_dipole(inputs.rate_body_rad_s[None], inputs.field_body_T[None], k_Nms=params["gain_Nms"])[0]
    return MagneticDipole(dipole_body_Am2=m)


def proportional_plugin(inputs: DetumbleInputs, params: Mapping[str, float]) -> MagneticDipole:
    """The proportional B-dot ``m = −K Ḃ`` with ``K = params["gain_Am2s_T"]``."""
    return MagneticDipole(dipole_body_Am2=-params["gain_Am2s_T"] * inputs.field_rate_body_T_s)


PLUGINS_SOURCE = """
import numpy as np
from magsail_mj.commands import MagneticDipole
from magsail_mj.control.detumble_laws import bcross_dipole


def bcross_plugin(inputs, params):
    m = bcross_dipole(inputs.rate_body_rad_s[None], inputs.field_body_T[None], k_Nms=params["gain_Nms"])[0]
    return MagneticDipole(dipole_body_Am2=m)
"""


@pytest.fixture
def registered():
    """The two plug-ins registered in this process for one test."""
    register_detumble_law("bcross_plugin", bcross_plugin)
    register_detumble_law("proportional_plugin", proportional_plugin)
    yield
    unregister_detumble_law("bcross_plugin")
    unregister_detumble_law("proportional_plugin")


def _law(name: str, **params: float) -> list[str]:
    table = ", ".join(f"{k} = {v!r}" for k, v in params.items())
    return [f'control.bdot_law="{name}"', f"control.bdot_law_params={{{table}}}"]


def _records(overrides: list[str]) -> dict[str, np.ndarray]:
    result = magsail_mj.load(str(PRE), overrides).run()
    assert result.status == "completed", result.message
    return {k: np.asarray(v) for k, v in result.records.items()}


def _assert_same_records(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key]), key


def test_a_plugin_restating_a_shipped_law_gives_its_run_bit_for_bit(registered):
    base = ["sim.duration_s=30", "initial.omega0_deg_s=[4.0, -6.0, 2.0]"]
    shipped = _records([*base, 'control.bdot_law="b_cross"', "control.bcross_gain_Nms=2e-4"])
    plugin = _records([*base, *_law("bcross_plugin", gain_Nms=2e-4)])
    _assert_same_records(shipped, plugin)
    shipped = _records([*base, "control.bdot_gain_Am2s_T=2e4"])
    plugin = _records([*base, *_law("proportional_plugin", gain_Am2s_T=2e4)])
    _assert_same_records(shipped, plugin)
    # and the parameter reaches the law: another gain gives other commands
    other = _records([*base, *_law("proportional_plugin", gain_Am2s_T=1e3)])
    assert not np.array_equal(other["dipole_cmd_Am2"], plugin["dipole_cmd_Am2"])


def test_worlds_with_plugins_equal_their_single_runs(registered):
    worlds = [
        _law("bcross_plugin", gain_Nms=2e-4),
        [*_law("proportional_plugin", gain_Am2s_T=3e4), "initial.omega0_deg_s=[2.0, 9.0, -4.0]"],
        ['control.bdot_law="non_monotonic"'],
        [],
    ]
    _, result = run_and_compare(str(PRE), ["sim.duration_s=30"], worlds, nthread=2)
    assert result.status == ["completed"] * len(worlds)


def _zero_law(inputs: DetumbleInputs, params: Mapping[str, float]) -> MagneticDipole:
    return MagneticDipole(dipole_body_Am2=np.zeros(3))


def _raising_law(inputs: DetumbleInputs, params: Mapping[str, float]) -> MagneticDipole:
    """The zero law until ``params["after_s"]``, then an error (a user's law with a bug)."""
    if inputs.t_s >= params["after_s"]:
        raise RuntimeError("law broke")
    return _zero_law(inputs, params)


@pytest.mark.parametrize("loads", ["python", "compiled"])
def test_a_plugin_that_raises_stops_its_world_alone(registered, loads):
    register_detumble_law("zero_law", _zero_law)
    register_detumble_law("raising_law", _raising_law)
    try:
        shared = ["sim.duration_s=12", f'sim.loads="{loads}"']
        worlds = [_law("bcross_plugin", gain_Nms=2e-4), _law("raising_law", after_s=4.0), []]
        result = magsail_mj.load(str(PRE), shared, world_overrides=worlds, nthread=2).run()
        assert result.status == ["completed", "failed", "completed"]
        broken = result.worlds[1]
        assert "'raising_law' raised RuntimeError at t = 4 s: law broke" in broken.message, broken.message
        # what it recorded before is kept: the zero law's run up to the failure, bit for bit
        zero = magsail_mj.load(str(PRE), [*shared, *_law("zero_law")]).run().records
        t = np.asarray(broken.records["t"])
        assert 0 < len(t) < len(zero["t"]) and t[-1] < 4.0
        assert_same_records(broken.records, {k: np.asarray(v)[: len(t)] for k, v in zero.items()}, "raising")
        for k in (0, 2):  # the others run on as their single runs
            single = magsail_mj.load(str(PRE), [*shared, *worlds[k]]).run()
            assert_same_records(result.worlds[k].records, single.records, f"world {k}")
    finally:
        unregister_detumble_law("zero_law")
        unregister_detumble_law("raising_law")


def test_the_environment_runs_a_plugin_as_its_shipped_policy(registered):
    overrides = ["sim.duration_s=20", *_law("bcross_plugin", gain_Nms=2e-4)]
    ref, _ = assert_shipped_policy_gives_the_run_summary(str(PRE), overrides)
    assert len(ref) > 40


def test_bad_names_parameters_and_commands_are_refused(registered):
    with pytest.raises(ConfigError, match=r"control\.bdot_law.*known are.*bcross_plugin"):
        load_config(PRE, ['control.bdot_law="cubic"'])
    with pytest.raises(ConfigError, match=r"control\.bdot_law_params.*shipped law 'proportional'"):
        load_config(PRE, ["control.bdot_law_params={gain_Nms = 1.0}"])
    with pytest.raises(ConfigError, match=r"control\.bdot_law_params"):
        load_config(PRE, [*_law("bcross_plugin"), "control.bdot_law_params={gain_Nms = inf}"])
    for name in ("b_cross", "Bad-Name", ""):
        with pytest.raises(ValueError, match="name"):
            register_detumble_law(name, bcross_plugin)
    with pytest.raises(ValueError, match="registered already"):
        register_detumble_law("bcross_plugin", proportional_plugin)
    with pytest.raises(ValueError, match="law: must be callable"):
        register_detumble_law("not_a_law", 3.0)  # type: ignore[arg-type]
    register_detumble_law("torque_law", lambda inputs, params: BodyTorque(torque_body_Nm=np.zeros(3)))
    try:
        result = magsail_mj.load(str(PRE), ["sim.duration_s=6", 'control.bdot_law="torque_law"']).run()
    except ValueError as err:
        assert "returned BodyTorque" in str(err) and "torque_law" in str(err)
    else:
        assert result.status == "failed" and "returned BodyTorque" in result.message
    finally:
        unregister_detumble_law("torque_law")


@pytest.fixture
def installed(tmp_path: Path):
    """A package ``my_laws`` installed as a distribution whose entry point declares ``my_bcross``
    (a directory on the path with the module and a ``.dist-info`` holding ``entry_points.txt``:
    what ``pip install`` leaves), visible to this process and to subprocesses via PYTHONPATH."""
    site = tmp_path / "site"
    (site / "my_laws").mkdir(parents=True)
    (site / "my_laws/__init__.py").write_text(PLUGINS_SOURCE)
    info = site / "my_laws-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: my-laws\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[magsail_mj.detumble_laws]\nmy_bcross = my_laws:bcross_plugin\n")
    sys.path.insert(0, str(site))
    yield site
    sys.path.remove(str(site))
    unregister_detumble_law("my_bcross")
    sys.modules.pop("my_laws", None)


def test_an_installed_entry_point_is_found_by_name_in_this_process(installed):
    assert "my_bcross" in detumble_law_names()
    base = ["sim.duration_s=20"]
    shipped = _records([*base, 'control.bdot_law="b_cross"', "control.bcross_gain_Nms=2e-4"])
    _assert_same_records(shipped, _records([*base, *_law("my_bcross", gain_Nms=2e-4)]))


def test_the_command_line_and_a_sweep_find_an_installed_law(installed, tmp_path):
    """``magsail run`` in a fresh process and a sweep's Dask worker processes find the law through
    the installed entry point alone (nothing is registered in them)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(installed), str(REPO)])}
    law = _law("my_bcross", gain_Nms=2e-4)
    run = [sys.executable, "-m", "magsail_mj", "run", str(PRE), "--out", str(tmp_path / "r"), "--no-progress"]
    for o in ["sim.duration_s=20", *law]:
        run += ["--set", o]
    proc = subprocess.run(run, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        f'name = "plugin_sweep"\nset = ["sim.duration_s=20", "sim.progress=false"]\n'
        f'[[run]]\nid = "shipped"\nconfig = "{PRE}"\n'
        'set = [\'control.bdot_law="b_cross"\', "control.bcross_gain_Nms=2e-4"]\n'
        f'[[run]]\nid = "plugin"\nconfig = "{PRE}"\nset = {json.dumps(law)}\n'
    )
    cmd = [sys.executable, "-m", "magsail_mj", "sweep", str(sweep), "--workers", "1", "--out", str(tmp_path / "s")]
    proc = subprocess.run([*cmd, "--no-progress"], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    records = {r["id"]: r for r in json.loads((tmp_path / "s/sweep_summary.json").read_text())}
    assert records["plugin"]["status"] == records["shipped"]["status"] == "completed"
    single = json.loads((tmp_path / "r/summary.json").read_text())
    numbers = {k: v for k, v in single.items() if isinstance(v, float) and "wall" not in k and "cost" not in k}
    assert len(numbers) > 10
    for summary in (records["plugin"]["summary"], records["shipped"]["summary"]):
        assert {k: summary[k] for k in numbers} == numbers


@pytest.mark.parametrize("law", ["proportional", "bang_bang", "b_cross", "non_monotonic"])
def test_a_shipped_law_validates_without_looking_at_installed_plug_ins(law, monkeypatch):
    """A sweep validates thousands of configs: a shipped law must not cost a look through every
    installed distribution's entry points (it was 80 % of the time of validating one config)."""
    import magsail_mj.control.detumble_plugins as plugins

    def no_look(**_: object) -> None:
        raise RuntimeError("entry points read")

    monkeypatch.setattr(plugins, "entry_points", no_look)
    assert load_config(PRE, [f'control.bdot_law="{law}"']).control.bdot_law == law
    with pytest.raises(RuntimeError, match="entry points read"):  # any other name does look
        load_config(PRE, ['control.bdot_law="not_a_law"'])
