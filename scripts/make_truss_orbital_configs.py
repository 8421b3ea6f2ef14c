"""Write the orbital truss configs of spec §9 (truss-magnetorquer-array.md):

    models/truss_magnetorquer/{detumble,slew_i,slew_ii,slew_iii,slew_iv,gg_ablation_slew_i}.toml
    models/truss_magnetorquer/sensitivity/<base>_<changed key>.toml      (§9.4 variants, §9.6)
    models/truss_magnetorquer/sweep_ablation_sensitivity.toml            (§9.5 + §9.6 as a sweep)

    python scripts/make_truss_orbital_configs.py && python scripts/build_models.py

Every file is written from one template, so the shared tables stay identical; a config differs
from its base only in the keys its name says. Quaternions are scalar-first, body → inertial
(§9.4 table, §12 item O10); R_a(β) is an active rotation by β about inertial axis a.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "models" / "truss_magnetorquer"


def rot(axis: str, deg: float) -> np.ndarray:
    """Quaternion [w, x, y, z] of an active rotation by ``deg`` about inertial ``axis``."""
    h = math.radians(deg) / 2
    v = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[axis]
    return np.array([math.cos(h), *(math.sin(h) * np.array(v))])


def qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    pw, pv, qw, qv = p[0], p[1:], q[0], q[1:]
    return np.array([pw * qw - pv @ qv, *(pw * qv + qw * pv + np.cross(pv, qv))])


def fmt(q: np.ndarray) -> str:
    q = np.where(np.abs(q) < 1e-15, 0.0, q)
    return "[" + ", ".join(repr(float(round(x, 15))) for x in q) + "]"


IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
SLEWS = {  # id: (q0, q_ref, description)
    "slew_i": (IDENTITY, rot("x", -90), "manoeuvre I: identity → R_x(−90°), about inertial x = orbit normal, "
                                        "against the gravity gradient; normal +z → +y"),
    "slew_ii": (IDENTITY, rot("x", 90), "manoeuvre II: identity → R_x(+90°), about x in the orbital sense; "
                                        "normal +z → −y"),
    "slew_iii": (rot("x", -90), qmul(rot("z", 90), rot("x", -90)),
                 "manoeuvre III: R_x(−90°) → R_z(+90°) R_x(−90°), about inertial z; normal +y → −x"),
    "slew_iv": (IDENTITY, rot("y", 90), "manoeuvre IV: identity → R_y(+90°), about inertial y; normal +z → +x"),
}

HEADER = """# {title}
# truss-magnetorquer-array.md §9 ({sections}). Written by scripts/make_truss_orbital_configs.py.
# 75 m truss, 20 × 20 nodes per layer (19 × 19 cubes, §12 E2), 800 particles of 0.25 kg
# (200 kg incl. 100 kg of rods spread uniformly, §12 S4), EI = 1e3 N m² calibrated (§2.7, S2),
# ζ_s = 0.1 (S5); rods in all 380 + 380 top-layer struts, κ_τ = 100 A m²/kg (§9.1, O4, O5);
# 800 km polar orbit in the ECI y–z plane from the ascending node, epoch 2020-01-01 (O7, O8),
# IGRF degree 13 at the centre of mass, tidal gravity on every particle (§3.3).
# Integrator: MuJoCo RK4 at 0.1 s, as the spec asks (§3.4); control every step (O6).
{note}concept = "truss_magnetorquer"
scenario = "{scenario}"
description = "{description}"

[sim]
duration_s = {duration}
timestep_s = 0.1
integrator = "RK4"
record_every = 10
seed = 0
checkpoint_every_s = 1800.0

[lattice]
units = 19
side_m = 75.0
diagonals = "parity"

[mass]
total_kg = 200.0

[stiffness]
EI_Nm2 = 1e3
calibration = "cantilever"

[damping]
zeta_strut = 0.1

[actuators]
kind = "magnetorquer"
kappa_Am2_per_kg = 100.0
rod_mass_kg = 100.0
rod_dipole_basis = "{basis}"

[initial]
omega0_rad_s = {omega0}
{maneuver}
[orbit]
enabled = true
altitude_km = 800.0
inclination_deg = 90.0
raan_deg = 90.0
arg_lat0_deg = 0.0
epoch = "{epoch}"
R_E_km = 6370.0
propagator = "kepler"

[field]
model = "igrf"
igrf_max_degree = 13
sample_step_s = 10.0

[gravity]
tidal = {tidal}

[control]
kind = "{kind}"
{control}allocation = "{allocation}"
cache_dir = "runs/lloyd_cache"
low_authority_threshold_Nm = 0.02

[control.lloyd]
tol_rel = 1e-6
max_iter = 10000

[render]
exaggeration = {exaggeration}
azimuth_deg = 135.0
elevation_deg = -25.0
distance_factor = 1.8
fps = 30
max_frames = 600
"""


def config(*, scenario: str, title: str, description: str, sections: str, duration: float,
           q0=None, q_ref=None, omega0=(0.0, 0.0, 0.0), basis="per_family", epoch="2020-01-01T00:00:00Z",
           tidal=True, gg_comp=True, gg_inertia=None, allocation="paper", note="", exaggeration=20.0) -> str:
    man = ""
    if q0 is not None or q_ref is not None:
        man = "\n[maneuver]\n"
        if q0 is not None:
            man += f"q0_wxyz = {fmt(q0)}\n"
        if q_ref is not None:
            man += f"q_ref_wxyz = {fmt(q_ref)}\n"
    if scenario == "detumble":
        kind, ctrl = "bdot", "k_bdot_Nms_per_T2 = 1e12\n"
    else:
        kind = "quat_pd"
        ctrl = ("Pq_Nm = [10.0, 50.0, 1.0]\nPw_Nms = [1600.0, 8000.0, 800.0]\n"
                f"gg_comp = {str(gg_comp).lower()}\n")
        if gg_inertia is not None:
            ctrl += f"gg_comp_inertia_kgm2 = {list(map(float, gg_inertia))}\n"
    note = "".join(f"# {line}\n" for line in note.splitlines())
    return HEADER.format(title=title, sections=sections, note=note, scenario=scenario,
                         description=description, duration=duration, basis=basis,
                         omega0=list(map(float, omega0)), maneuver=man, epoch=epoch,
                         tidal=str(tidal).lower(), kind=kind, control=ctrl, allocation=allocation,
                         exaggeration=exaggeration)


DETUMBLE = dict(scenario="detumble", title="B-dot detumbling of the 75 m truss, 2.5 h",
                description="B-dot detumble, 75 m truss, 800 km polar orbit", sections="§9.3",
                duration=9000.0, omega0=(0.01, 0.007, 0.0),
                note="Initial rate (0.01, 0.007, 0) rad/s: the paper's text value (§12 O1); identity "
                     "attitude (O11).\nk_Bdot = 1e12 N m s/T² (§9.3).")


def slew(sid: str, **kw) -> dict:
    q0, q_ref, what = SLEWS[sid]
    base = dict(scenario="slew", title=f"Slew {sid[5:].upper()}: {what}, 4.2 h",
                description=f"slew {sid[5:].upper()}: " + what.split(": ", 1)[1].split(",")[0],
                sections="§9.4", duration=15120.0, q0=None if np.allclose(q0, IDENTITY) else q0, q_ref=q_ref,
                note="Quaternion feedback q_e = q_ref* ⊗ q_t (§12 O2), P_q = diag(10, 50, 1) N m,\n"
                     "P_ω = diag(1600, 8000, 800) N m s (O9), gravity-gradient compensation with the\n"
                     "Eq. 21 inertia (O3). Attitudes: §9.4 table (O10).")
    base.update(kw)
    return base


def main() -> None:
    files: dict[str, str] = {"detumble.toml": config(**DETUMBLE)}
    for sid in SLEWS:
        files[f"{sid}.toml"] = config(**slew(sid))
    files["gg_ablation_slew_i.toml"] = config(**slew(
        "slew_i", title="Gravity-gradient ablation of slew I (§9.5): no tidal loading, no compensation",
        description="slew I without tidal loading (ablation)", sections="§9.5", tidal=False, gg_comp=False))
    sens = {
        "detumble_rod_dipole_basis_total": config(**{**DETUMBLE, "basis": "total",
                                                     "title": "Detumble with rod_dipole_basis = total "
                                                              "(13.16 A m² per rod, §9.6, §12 O4)"}),
        "detumble_omega0_table2": config(**{**DETUMBLE, "omega0": (0.01, 0.07, 0.0),
                                            "title": "Detumble with the Table 2 rate (0.01, 0.07, 0) rad/s "
                                                     "(§9.6, §12 O1)"}),
        "detumble_allocation_exact": config(**{**DETUMBLE, "allocation": "exact",
                                               "title": "Detumble with allocation = exact (§9.6, §12 T5)"}),
        "detumble_epoch_2020_07_01": config(**{**DETUMBLE, "epoch": "2020-07-01T00:00:00Z",
                                               "title": "Detumble with epoch 2020-07-01 (§9.6: field geometry)"}),
        "slew_i_rod_dipole_basis_total": config(**slew(
            "slew_i", basis="total", title="Slew I with rod_dipole_basis = total (§9.6, §12 O4)")),
        "slew_i_gg_comp_inertia_printed": config(**slew(
            "slew_i", gg_inertia=(1893, 1893, 2867),
            title="Slew I with the paper's printed inertia in the compensation (§9.6, §12 O3)")),
        "slew_i_allocation_exact": config(**slew(
            "slew_i", allocation="exact", title="Slew I with allocation = exact (§9.6, §12 T5)")),
        "slew_iii_q_ref_Rz_minus90": config(**slew(
            "slew_iii", q_ref=qmul(rot("z", -90), rot("x", -90)),
            description="slew III reversed: R_x(−90°) → R_z(−90°) R_x(−90°)",
            title="Slew III in the opposite sense: R_x(−90°) → R_z(−90°) R_x(−90°) (§9.4 variant)")),
        "slew_iv_q_ref_Ry_minus90": config(**slew(
            "slew_iv", q_ref=rot("y", -90), description="slew IV reversed: identity → R_y(−90°)",
            title="Slew IV in the opposite sense: identity → R_y(−90°) (§9.4 variant)")),
    }
    for name, text in sens.items():
        tag = f"sensitivity: {name}"
        text = text.replace('\ndescription = "', f'\ndescription = "[{tag}] ', 1)
        files[f"sensitivity/{name}.toml"] = text
    runs = ["gg_ablation_slew_i", *(f"sensitivity/{name}" for name in sens)]
    files["sweep_ablation_sensitivity.toml"] = "\n".join([
        "# The gravity-gradient ablation (§9.5) and the sensitivity runs (§9.6, §9.4 variants) as one sweep.",
        "# magsail sweep models/truss_magnetorquer/sweep_ablation_sensitivity.toml --workers 2 \\",
        "#     --out runs/truss_orbital/sweep_ablation_sensitivity",
        "# (scripts/truss_orbital.py --all runs the same configs and tabulates the slew/detumble keys.)",
        'name = "sweep_ablation_sensitivity"',
        'description = "truss-magnetorquer-array §9.5 ablation and §9.6 sensitivity runs"',
        *(f'\n[[run]]\nid = "{rid}"\nconfig = "{rid}.toml"' for rid in runs),
        "",
    ])
    for rel, text in files.items():
        path = OUT / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        print(f"wrote {path.relative_to(OUT.parents[1])}")


if __name__ == "__main__":
    main()
