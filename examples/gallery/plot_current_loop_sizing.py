"""
Current-loop sizing: the loop currents, wire and mass of Table 2 and the trends of Figs. 3-5
============================================================================================

The thermal and length-scaling model of the current-loop paper (Robb et al. 2022b, Eqs. 2-11),
no simulation. A loop of enclosed area ``A_e`` [m²] must carry the current that makes its dipole
``m = I A_e`` [A·m²] cancel the largest gravity-gradient torque on the plate (Eq. 9,
``I = μ σ_A D⁴ / (8 A_e B0 R_E³)`` for a square plate of side ``D`` [m] and areal density
``σ_A`` [kg/m²]); the wire is as thin as the Joule heat it must radiate allows, which fixes its
diameter ``d`` [m], the conductor mass fraction ``λ_f`` and the Joule power ``P_J`` [W].

Geometry A (one loop around the rim) is implicit, ``λ_f = λ_u (1 + κ λ_f)^{4/3}``, with a light
and a heavy branch that meet at a fold; B, C and D (many loops; in-plane and through the depth)
are power laws in ``D`` with a largest plate ``D_max`` where ``λ_f = 1``. The same numbers come
from ``magsail scaling loops`` (one JSON object) and
:func:`magsail_mj.analysis.loop_scaling.loop_sizing` / ``scaling_table``.
"""

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

from magsail_mj.analysis.loop_scaling import (
    GEOMETRIES,
    c1,
    fold_A,
    geometry_factor_b_loops,
    loop_sizing,
    radiated_power,
    required_current,
    side_max,
    table1,
    trace_branches_A,
    uniform_curves,
    wire_diameter,
)

SIDE_M = 250.0  # plate side of the paper's simulations [m]
SIGMA_KG_M2 = 0.1  # areal density, 100 g/m²
KAPPA_RIM = 15.0  # geometry A's rim-inertia factor (the paper's value)
UNITS = (12, 19, 27)  # cubic units per side of the simulated lattices
SIGMAS_KG_M2 = (1e-3, 1e-2, 1e-1)  # 1, 10, 100 g/m² for the trends

# %%
# Table 2: the loops of the simulated plates
# ------------------------------------------
# ``D = 250 m``, ``σ_A = 100 g/m²`` (A on its light branch). The dipole ``m_max`` is the same for
# B, C and D (it only depends on the plate); A needs ``(1 + κ λ_f)`` times more because its
# conductor sits on the rim.

rows = [
    loop_sizing(g, units=n, side_m=SIDE_M, areal_density_kg_m2=SIGMA_KG_M2, kappa=KAPPA_RIM)
    for g in GEOMETRIES
    for n in UNITS
]
print(f"C1 = {c1():.5e} m⁻¹ kg^(-1/3)")
print("| geometry | N | I [A] | d [mm] | λ_f [%] | P_J/D² [W/m²] | m_max [A m²] | path [m] |")
print("|---|---|---|---|---|---|---|---|")
for r in rows:
    print(
        f"| {r['geometry']} | {r['units']} | {r['current_A']:.2f} | {r['wire_diameter_m'] * 1e3:.3f} "
        f"| {r['lambda_f'] * 100:.3f} | {r['power_per_area_W_m2']:.3f} | {r['dipole_max_Am2']:.4e} "
        f"| {r['path_length_m']:.0f} |"
    )

panels = (
    ("current_A", "current I [A]", 1.0),
    ("wire_diameter_m", "wire diameter d [mm]", 1e3),
    ("lambda_f", "conductor mass fraction λ_f [%]", 100.0),
    ("power_per_area_W_m2", "Joule power P_J/D² [W/m²]", 1.0),
)
fig, axes = plt.subplots(2, 2, figsize=(10, 7))
x = np.arange(len(GEOMETRIES))
width = 0.26
for ax, (key, label, scale) in zip(axes.ravel(), panels):
    for j, n in enumerate(UNITS):
        values = [scale * next(r[key] for r in rows if r["geometry"] == g and r["units"] == n) for g in GEOMETRIES]
        bars = ax.bar(x + (j - 1) * width, values, width, label=f"N = {n} units per side")
        ax.bar_label(bars, fmt="%.3g", fontsize=6, padding=1)
    ax.set_xticks(x, [f"geometry {g}" for g in GEOMETRIES])
    ax.set_ylabel(label)
    ax.grid(True, axis="y", alpha=0.3)
axes[0, 0].legend(fontsize=8)
fig.suptitle(
    f"Eq. 9 loop sizing, D = {SIDE_M:g} m, σ_A = {SIGMA_KG_M2 * 1e3:g} g/m² (A: light branch, κ = {KAPPA_RIM:g})"
)
fig.tight_layout()

# %%
# Fig. 3: geometry A against the plate size, both branches
# --------------------------------------------------------
# Solid: light branch; dashed: heavy branch; circle: the fold ``λ* = 3/κ``, beyond which no
# loop around the rim can hold the plate; star: ``λ_f = 1``.

lam_star = fold_A(KAPPA_RIM)[0]
lambdas = np.unique(np.append(np.logspace(-14, 0, 800), lam_star))
quantities = (
    ("lambda_f", "conductor mass fraction λ_f [-]"),
    ("wire_diameter_m", "wire diameter d [m]"),
    ("current_A", "current I [A]"),
    ("power_per_area_W_m2", "Joule power P_J/D² [W/m²]"),
)
fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
for k, sigma in enumerate(SIGMAS_KG_M2):
    branch = trace_branches_A(sigma, kappa=KAPPA_RIM, lambdas=lambdas)
    colour = f"C{k}"
    heavy = branch["heavy"]
    light_idx = np.flatnonzero(~heavy & (branch["side_m"] >= 10.0 / 1.05))
    heavy_idx = np.concatenate([light_idx[-1:], np.flatnonzero(heavy)])  # the branches join at the fold
    i_fold = int(np.argmin(np.abs(branch["lambda_f"] - lam_star)))
    i_one = int(np.argmin(np.abs(branch["lambda_f"] - 1.0)))
    for ax, (key, label) in zip(axes.ravel(), quantities):
        y = branch[key]
        name = f"σ_A = {sigma * 1e3:g} g/m²" if key == "lambda_f" else None
        ax.plot(branch["side_m"][light_idx], y[light_idx], "-", color=colour, label=name)
        ax.plot(branch["side_m"][heavy_idx], y[heavy_idx], "--", color=colour)
        ax.plot(branch["side_m"][i_fold], y[i_fold], "o", color=colour, mfc="white", ms=7)
        ax.plot(branch["side_m"][i_one], y[i_one], "*", color=colour, ms=12)
    print(
        f"A, σ_A = {sigma * 1e3:g} g/m²: fold at D = {branch['side_m'][i_fold]:.0f} m, "
        f"λ_f = 1 (heavy branch) at D = {branch['side_m'][i_one]:.0f} m"
    )
for ax, (key, label) in zip(axes.ravel(), quantities):
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(10.0, 1e5)
    ax.set_ylabel(label)
    ax.grid(True, which="both", alpha=0.25)
axes[0, 0].set_ylim(1e-6, 2.0)
for ax in axes[1]:
    ax.set_xlabel("plate side D [m]")
handles, labels = axes[0, 0].get_legend_handles_labels()
handles += [
    Line2D([], [], ls="-", color="k"),
    Line2D([], [], ls="--", color="k"),
    Line2D([], [], ls="", marker="o", mfc="white", color="k"),
    Line2D([], [], ls="", marker="*", color="k", ms=10),
]
labels += ["light branch", "heavy branch", f"fold λ* = 3/κ = {lam_star:.3g}", "λ_f = 1"]
axes[0, 0].legend(handles, labels, fontsize=7, loc="lower right")
fig.suptitle(f"Geometry A (rim loop), κ = {KAPPA_RIM:g}: λ_f = λ_u (1 + κ λ_f)^(4/3)")
fig.tight_layout()

# %%
# Fig. 4: geometries B, C and D at N = 27
# ---------------------------------------
# Uniform mass: every quantity is a power law in ``D``. Colour: geometry; line style: areal
# density; star: ``D_max`` (``λ_f = 1``); faint: beyond it.

side_m = np.logspace(1, 5, 401)
styles = ("-", "--", ":")
colours = {"B": "tab:blue", "C": "tab:green", "D": "tab:red"}
fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
for g in ("B", "C", "D"):
    for sigma, style in zip(SIGMAS_KG_M2, styles):
        curve = uniform_curves(g, units=27, side_m=side_m, areal_density_kg_m2=sigma)
        d_max = side_max(g, units=27, areal_density_kg_m2=sigma)
        area, length = table1(g, 27, d_max)
        current_max = required_current(area, d_max, sigma)
        diameter_max = wire_diameter(current_max)
        at_max = {
            "lambda_f": 1.0,
            "wire_diameter_m": diameter_max,
            "current_A": current_max,
            "power_per_area_W_m2": radiated_power(diameter_max, length) / d_max**2,
        }
        inside = curve["side_m"] <= d_max
        for ax, (key, _) in zip(axes.ravel(), quantities):
            name = f"{g}, σ_A = {sigma * 1e3:g} g/m²" if key == "lambda_f" else None
            ax.plot(curve["side_m"][inside], curve[key][inside], style, color=colours[g], label=name)
            ax.plot(curve["side_m"][~inside], curve[key][~inside], style, color=colours[g], alpha=0.25)
            ax.plot(d_max, at_max[key], "*", color=colours[g], ms=10)
        print(f"{g}, N = 27, σ_A = {sigma * 1e3:g} g/m²: D_max = {d_max:.0f} m")
for ax, (key, label) in zip(axes.ravel(), quantities):
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(side_m[0], side_m[-1])
    ax.set_ylabel(label)
    ax.grid(True, which="both", alpha=0.25)
axes[0, 0].axhline(1.0, color="k", lw=0.8, ls=":")
axes[0, 0].set_ylim(1e-6, 1e2)
for ax in axes[1]:
    ax.set_xlabel("plate side D [m]")
axes[0, 0].legend(fontsize=7, loc="upper left")
fig.suptitle("Geometries B, C, D at N = 27 (uniform mass); ★ = D_max (λ_f = 1), faint beyond it")
fig.tight_layout()

# %%
# Fig. 5: the largest plate against the number of coils
# -----------------------------------------------------
# ``D_max = (C1 G σ_A^{1/3})^{-3/5}``: B against its loop count ``n`` and against the units per side
# ``N`` (``n = ⌈N/2⌉``), C and D against ``N``; the rim loop A (uniform mass and its fold) for
# reference.

counts = np.arange(2, 61)
h_star = fold_A(KAPPA_RIM)[1]
fig, axes = plt.subplots(1, len(SIGMAS_KG_M2), figsize=(4.6 * len(SIGMAS_KG_M2), 4.6))
for ax, sigma in zip(axes, SIGMAS_KG_M2):
    s3 = np.cbrt(sigma)
    b_vs_n = [(c1() * geometry_factor_b_loops(int(n)) * s3) ** -0.6 for n in counts]
    ax.plot(counts, b_vs_n, "-", color="tab:blue", label="B against loop count n")
    for g, style, colour in (("B", "--", "tab:blue"), ("C", "-", "tab:green"), ("D", "-", "tab:red")):
        d_max = [side_max(g, units=int(n), areal_density_kg_m2=sigma) for n in counts]
        label = "B against units N (n = ⌈N/2⌉)" if g == "B" else f"{g} against units N"
        ax.plot(counts, d_max, style, color=colour, label=label)
    ax.axhline(side_max("A", units=1, areal_density_kg_m2=sigma), color="0.3", lw=0.8, ls=":", label="A, uniform mass")
    ax.axhline((h_star / (4.0 * c1() * s3)) ** 0.6, color="0.3", lw=0.8, ls="-.", label=f"A, fold (κ = {KAPPA_RIM:g})")
    ax.set_yscale("log")
    ax.set_xlabel("number of coils (n for B solid, N otherwise) [-]")
    ax.set_title(f"σ_A = {sigma * 1e3:g} g/m²")
    ax.grid(True, which="both", alpha=0.25)
axes[0].set_ylabel("largest side D_max (λ_f = 1) [m]")
axes[0].legend(fontsize=7)
fig.suptitle("D_max = (C1 G σ_A^(1/3))^(-3/5)")
fig.tight_layout()
plt.show()
