"""A structure's time step is checked in validation: a step past the stability limit of its
stiffest mode is refused naming ``sim.timestep_s`` (its run would blow up and read as a failed
structure). The probe (:func:`magsail_mj.structure.stability.step_growth`) against the analytic
limits of a two-mass spring: ``ω Δt = 2`` (semi-implicit Euler) and ``2.785`` (RK4)."""

from __future__ import annotations

import math

import mujoco
import pytest

from magsail_mj.config import ConfigError, parse_config
from magsail_mj.structure.stability import UNSTABLE_GROWTH, largest_stable_fraction, step_growth

STIFFNESS_N_M, MASS_KG = 1000.0, 1.0
OMEGA_RAD_S = math.sqrt(2 * STIFFNESS_N_M / MASS_KG)  # the pair's one elastic mode
LIMITS = {"Euler": 2.0, "RK4": 2.785}  # ω Δt at the edge of the undamped stability region


def _pair(integrator: str, timestep_s: float) -> mujoco.MjModel:
    xml = f"""<mujoco><option timestep="{timestep_s}" integrator="{integrator}" gravity="0 0 0"/><worldbody>
<body><joint type="slide" axis="1 0 0"/><geom size=".1" mass="{MASS_KG}" contype="0" conaffinity="0"/>
<site name="a"/></body>
<body pos="1 0 0"><joint type="slide" axis="1 0 0"/><geom size=".1" mass="{MASS_KG}" contype="0" conaffinity="0"/>
<site name="b"/></body></worldbody>
<tendon><spatial stiffness="{STIFFNESS_N_M}" springlength="1"><site site="a"/><site site="b"/></spatial>
</tendon></mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


@pytest.mark.parametrize("integrator", ["Euler", "RK4"])
@pytest.mark.parametrize("ratio", [0.5, 0.97, 1.03, 1.5])
def test_growth_separates_the_analytic_stability_limit(integrator, ratio):
    """Below the limit the rigid translation's linear growth reads 1.007; 3 % past it the elastic
    mode grows geometrically, above 1.05."""
    model = _pair(integrator, ratio * LIMITS[integrator] / OMEGA_RAD_S)
    growth = step_growth(model)
    if ratio < 1:
        assert 1.0 <= growth < UNSTABLE_GROWTH, growth
    else:
        assert growth > UNSTABLE_GROWTH, growth


def test_largest_stable_fraction_halves_to_below_the_limit():
    model = _pair("RK4", 3.0 * LIMITS["RK4"] / OMEGA_RAD_S)
    assert largest_stable_fraction(model) == 0.25  # 3/2 of the limit still unstable, 3/4 stable
    assert model.opt.timestep == pytest.approx(3.0 * LIMITS["RK4"] / OMEGA_RAD_S)  # restored


def _strut_config(timestep_s: float) -> dict:
    """Two 1 kg nodes on a 1 m strut of EA = 1000 N (k = 1000 N/m): ω = √(2k/m)."""
    return {
        "concept": "structure",
        "scenario": "free",
        "sim": {"duration_s": 1.0, "timestep_s": timestep_s, "integrator": "RK4", "progress": False},
        "structure": {
            "nodes": {"position_m": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], "mass_kg": MASS_KG},
            "member_groups": [{"kind": "strut", "name": "s", "nodes": [[0, 1]], "EA_N": STIFFNESS_N_M}],
        },
    }


def test_a_structure_config_with_an_unstable_step_is_refused_naming_the_key():
    stable = 0.9 * LIMITS["RK4"] / OMEGA_RAD_S
    parse_config(_strut_config(stable))
    with pytest.raises(ConfigError) as err:
        parse_config(_strut_config(2 * stable))
    text = str(err.value)
    assert "sim.timestep_s:" in text and "is unstable for this structure with RK4" in text
    assert f"sim.timestep_s = {stable:.6g} s (0.5 of it) is stable" in text
