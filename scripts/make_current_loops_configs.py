"""Write the current-loops scenario configs (current-loops spec §5, §6, §7.1).

    python scripts/make_current_loops_configs.py          # then: python scripts/build_models.py

Creates ``models/current_loops/``:

* ``sweep/<g>_n<N>_ei<E>.toml`` — the 36 S4 runs (g ∈ a, b, cy, dy; N ∈ 12, 19, 27;
  EI ∈ 1e3, 1e4, 1e5 with Δt = 0.1, 0.05, 0.01 s), field 27.7 μT along +x (§9 item 4);
* ``sweep_mirror/<g>_n19_ei1e4.toml`` — C_x and D_x with the field along +y (symmetry check);
* ``sweep36.toml`` — the sweep file of the 36 runs (``magsail sweep … --workers K``);
* ``slew.toml`` and ``slew_rigid.toml`` — S5 and its rigid-body surrogate.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "models" / "current_loops"
GEOMETRIES = {"a": "A", "b": "B", "cy": "C_y", "dy": "D_y"}
MIRRORS = {"cx": "C_x", "dx": "D_x"}
UNITS = (12, 19, 27)
EIS = {"1e3": (1e3, 0.1), "1e4": (1e4, 0.05), "1e5": (1e5, 0.01)}
RECORD_INTERVAL_S = 2.0

HEADER = """\
# {title}
# current-loops.md §{section}. Written by scripts/make_current_loops_configs.py.
# 250 m plate, σ_A = 100 g/m² (M = 6250 kg, uniform particle masses, §1), EI calibrated by the
# formula EA_c = 2 EI / ((N+1) w²) (§1, §9 item 12), exact tendon springs, Caughey damping with
# the paper_max schedule (§4.4, §9 item 6) co-rotated and held per step (xfrc).
# Currents: Eq. 9 of this geometry and N (§3 item 1; A on the light branch with κ = 15, §9 item 5).
"""


def _sweep(title: str, section: str, circuit: str, N: int, EI: float, dt: float,
           field: tuple[float, float, float]) -> str:
    rec = int(round(RECORD_INTERVAL_S / dt))
    return HEADER.format(title=title, section=section) + f"""\
# Field: uniform, constant, 27.7 μT (the paper's tabulated value, §9 item 4), along {field_name(field)}.
concept = "current_loops"
scenario = "sweep"
description = "{title}"

[sim]
duration_s = 4000.0
timestep_s = {dt}
integrator = "RK4"
record_every = {rec}
seed = 0

[lattice]
units = {N}
side_m = 250.0
diagonals = "parity"

[mass]
areal_density_kg_m2 = 0.1

[stiffness]
EI_N_m2 = {EI:.0e}
calibration = "formula"

[damping]
schedule = "paper_max"
xi_low = 0.01
n_low = 100
xi_cap = 10.0
frame = "body"

[loops]
circuits = ["{circuit}"]
sizing = "eq9"
kappa = 15.0

[field]
model = "constant"
constant_T = [{field[0]:.4g}, {field[1]:.4g}, {field[2]:.4g}]

[render]
exaggeration = 1.0
fps = 30
max_frames = 400
"""


def field_name(f: tuple[float, float, float]) -> str:
    return "+x" if f[0] > 0 else "+y"


SLEW = """\
# {title}
# current-loops.md §6 (S5). Written by scripts/make_current_loops_configs.py.
# 250 m plate, N = 19 (800 particles), σ_A = 100 g/m², EI = 1e4 N m² (formula calibration, §1),
# circuits [C_x, C_y, B] at their Eq.-9 full currents (§3 item 1, N = 19); m_max = μσD⁴/(8B0R_E³).
# Circular polar orbit, 800 km, R_E = 6370 km, CM at ECI (R_o, 0, 0) moving along +z (inclination
# 90°, RAAN 0, from the ascending node), epoch 2022-01-01; IGRF (ppigrf) along the reference orbit,
# tidal gravity on every particle{rigid_note}.
# Quaternion PD k_p = 600 N m, k_ω = 4e5 N m s (Eq. 18), m_d = B_b × T_ref / |B_b|² (Eq. 19
# corrected, §9 item 9), per-axis current clipping (Eq. 20 as intended, §9 item 10), every step.
# Target: +90° about inertial y, q_d = [cos 45°, 0, sin 45°, 0].
concept = "current_loops"
scenario = "{scenario}"
description = "{title}"

[sim]
duration_s = 10000.0
timestep_s = 0.05
integrator = "RK4"
record_every = 40
seed = 0
checkpoint_every_s = 1000.0

[lattice]
units = 19
side_m = 250.0
diagonals = "parity"

[mass]
areal_density_kg_m2 = 0.1

[stiffness]
EI_N_m2 = 1e4
calibration = "formula"

[damping]
enabled = {damping}
schedule = "paper_max"
frame = "body"

[loops]
circuits = ["C_x", "C_y", "B"]
sizing = "eq9"
kappa = 15.0

[control]
kp_N_m = 600.0
kw_N_m_s = 4e5
q_target = [0.7071067811865476, 0.0, 0.7071067811865476, 0.0]
allocation = "paper_clip"

[orbit]
enabled = true
altitude_km = 800.0
inclination_deg = 90.0
raan_deg = 0.0
arg_lat0_deg = 0.0
epoch = "2022-01-01T00:00:00Z"
R_E_km = 6370.0
propagator = "kepler"

[field]
model = "igrf"
igrf_max_degree = 13
sample_step_s = 10.0

[gravity]
tidal = true

[render]
exaggeration = 1.0
azimuth_deg = 120.0
elevation_deg = -20.0
fps = 30
max_frames = 500
"""


def main() -> None:
    entries = []
    for g, circuit in GEOMETRIES.items():
        for N in UNITS:
            for tag, (EI, dt) in EIS.items():
                rid = f"{g}_n{N}_ei{tag}"
                title = f"S4 sweep: geometry {circuit}, N = {N}, EI = {tag} N m²"
                path = ROOT / "sweep" / f"{rid}.toml"
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(_sweep(title, "5 (S4)", circuit, N, EI, dt, (27.7e-6, 0.0, 0.0)))
                entries.append(f'[[run]]\nid = "sweep/{rid}"\nconfig = "sweep/{rid}.toml"\n')
    for g, circuit in MIRRORS.items():
        rid = f"{g}_n19_ei1e4"
        path = ROOT / "sweep_mirror" / f"{rid}.toml"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(_sweep(f"S4 mirror: geometry {circuit}, N = 19, EI = 1e4 N m², field +y", "5 (S4, symmetry)",
                               circuit, 19, 1e4, 0.05, (0.0, 27.7e-6, 0.0)))
    (ROOT / "sweep36.toml").write_text(
        "# The 36 runs of current-loops.md §5 (S4): geometries A, B, C_y, D_y × N 12/19/27 × EI 1e3/1e4/1e5.\n"
        "# magsail sweep models/current_loops/sweep36.toml --workers 2 --out runs/current_loops/sweep36\n"
        'name = "sweep36"\ndescription = "current-loops §5: 36-run structural sweep"\n\n' + "\n".join(entries))
    (ROOT / "slew.toml").write_text(SLEW.format(title="S5: 90° slew of the 250 m plate", scenario="slew",
                                                damping="true", rigid_note=""))
    (ROOT / "slew_rigid.toml").write_text(SLEW.format(
        title="S5 rigid-body surrogate: one body with the lattice inertia", scenario="slew_rigid", damping="false",
        rigid_note=" (here: classical gravity-gradient torque on the one body)"))
    print(f"wrote {len(entries)} sweep configs, 2 mirror configs, sweep36.toml, slew.toml, slew_rigid.toml in {ROOT}")


if __name__ == "__main__":
    main()
