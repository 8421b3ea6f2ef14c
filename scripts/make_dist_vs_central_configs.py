"""Writes the 12 dist_vs_central configs."""
from pathlib import Path
EI = {"a": 1e3, "b": 1e2, "c": 1e1}
PROFILE = {"bangbang": "bang_bang_off", "versine": "versine"}
out = Path("models/truss_magnetorquer/dist_vs_central")
for case, ei in EI.items():
    for place in ("distributed", "central"):
        for prof, kind in PROFILE.items():
            frac = "0.0" if place == "distributed" else "0.3333333333333333"
            text = f'''# Distributed vs centralised torque, Case {case.upper()} (EI = {ei:g} N m^2), {place}, {kind}.
# truss-magnetorquer-array.md §6: 100 m, 20 x 20 nodes per layer (19 x 19 cubes), 100 kg,
# tau_max = 0.1 N m about x1, 1800 s, RK4 at 0.1 s, free space.
concept = "truss_magnetorquer"
scenario = "dist_vs_central"
description = "Case {case.upper()}, {place}, {prof}"

[sim]
duration_s = 1800.0
timestep_s = 0.1
integrator = "RK4"
record_every = 10
seed = 0

[lattice]
units = 19
side_m = 100.0
diagonals = "parity"

[mass]
total_kg = 100.0
central_fraction = {frac}   # actuator third on the central cube (spec §2.3, S3)

[stiffness]
EI_Nm2 = {ei:g}
calibration = "cantilever"

[damping]
zeta_strut = 0.1

[actuators]
kind = "generic"
placement = "{place}"
central_pair = "top"
torque_axis = "local"

[profile]
kind = "{kind}"
tau_max_Nm = 0.1
t_end_s = 1800.0
axis = "x1"
'''
            (out / f"case_{case}_{place}_{prof}.toml").write_text(text)
