"""Write the MSAC sweep configs models/msac/sweeps/*.toml (spec msac.md §5.5, §8 F6/F7).

Each sweep file is its base config (``paper_1khz.toml``) with ``scenario = "sweep"``, its own
description and a ``[sweep]`` table naming the base, the swept keys and the points; every
point runs ``cycles`` cycles with the base's 200 steps per cycle (the timestep is rescaled with
the cycle period). ``tests/test_msac_configs.py`` checks the files equal the base elsewhere.

    python scripts/msac_make_sweep_configs.py            # (re)write the files
    python scripts/build_models.py                       # then regenerate their MJCF
"""

from __future__ import annotations

import json
from pathlib import Path

MODELS = Path(__file__).resolve().parents[1] / "models" / "msac"
BASE = "paper_1khz"

#: amplification factors of the design chart (spec §4): extension 0.1 %·a, frequency 4 kHz/a
AMPLIFICATION = (1.0, 2.0, 5.0, 10.0, 20.0, 50.0)

SWEEPS: dict[str, tuple[str, list[str], list[list]]] = {
    "stroke": ("F6: bend stroke 10 deg (0/+10) and 20 deg (-10/+10)", ["cycle.bend_b_deg"], [[0.0], [-10.0]]),
    "extension": ("F6: extension 0.1, 0.5, 1, 2 % of the wing length", ["cycle.extension_frac"],
                  [[0.001], [0.005], [0.01], [0.02]]),
    "areal_density": ("F6: panel areal density 1, 2.5, 5 kg/m^2", ["wings.areal_density_kg_m2"],
                      [[1.0], [2.5], [5.0]]),
    "bus_inertia": ("F6: bus inertia x0.5, x1, x2", ["bus.inertia_scale"], [[0.5], [1.0], [2.0]]),
    "hinge_offset": ("F6: hinge offset r0 = 0, 0.5, 1 m", ["wings.hinge_offset_m"], [[0.0], [0.5], [1.0]]),
    "phase_fractions": ("F6: phase-time fractions (bend/prismatic) 0.45/0.05, 0.4/0.1, 0.3/0.2",
                        ["cycle.phase_fractions"],
                        [[[0.45, 0.05, 0.45, 0.05]], [[0.4, 0.1, 0.4, 0.1]], [[0.3, 0.2, 0.3, 0.2]]]),
    "frequency": ("F6: cycle frequency 1 Hz ... 4 kHz (per-cycle rotation flat, rate proportional)",
                  ["cycle.frequency_Hz"], [[1.0], [10.0], [100.0], [1000.0], [4000.0]]),
    "amplification": ("F7: actuator amplification a: extension 0.1 % x a at 4 kHz / a",
                      ["cycle.extension_frac", "cycle.frequency_Hz"],
                      [[round(0.001 * a, 6), round(4000.0 / a, 6)] for a in AMPLIFICATION]),
}


def toml_value(v) -> str:
    """TOML literal of a number, string or (nested) list."""
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(float(v)) if isinstance(v, float) else str(v)


def sweep_text(name: str) -> str:
    """The TOML text of sweep ``name``."""
    desc, keys, points = SWEEPS[name]
    base = (MODELS / f"{BASE}.toml").read_text()
    body = base[base.index('concept = "msac"'):]
    body = body.replace('scenario = "multibody"', 'scenario = "sweep"', 1)
    lines = body.splitlines()
    lines = [f"description = {json.dumps(desc)}" if ln.startswith("description = ") else ln for ln in lines]
    head = (f"# MSAC sweep '{name}' (spec msac.md §8 F6/F7), written by scripts/msac_make_sweep_configs.py.\n"
            f"# Base: {BASE}.toml (all other tables equal it); each point runs [sweep].cycles cycles with\n"
            f"# the base's 200 steps per cycle. "
            f"Run: magsail run models/msac/sweeps/{name}.toml --out runs/msac/sweeps/{name}\n")
    sweep = ["", "[sweep]", f"base = {json.dumps(BASE)}", f"keys = {toml_value(keys)}",
             f"points = {toml_value(points)}", "cycles = 20", "keep_steps_per_cycle = true", ""]
    return head + "\n".join(lines).rstrip() + "\n" + "\n".join(sweep)


def main() -> None:
    out = MODELS / "sweeps"
    out.mkdir(parents=True, exist_ok=True)
    for name in SWEEPS:
        (out / f"{name}.toml").write_text(sweep_text(name))
        print(f"wrote {out / f'{name}.toml'}")


if __name__ == "__main__":
    main()
