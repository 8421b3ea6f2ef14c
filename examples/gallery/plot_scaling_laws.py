"""
Scaling laws: how large can a magnetically steered structure be?
================================================================

Two analytic results, no simulation.

**Magnetorquer rods** (truss concept). The largest gravity-gradient torque on a square plate of
side ``d`` [m] and mass ``M`` [kg] on a circular orbit of radius ``r`` [m] is
``T_gg = μ M d² / (8 r³)`` [N·m]; rods of dipole-to-mass ratio ``κ`` [A·m²/kg] and mass
``M_τ`` in the dipole field ``B = B0 (R_E / r)³`` [T] give at most ``T_ac = κ M_τ B``. Matching
the two asks for the rod mass fraction ``λ_f = M_τ / M = μ d² / (8 r³ κ B) = μ d² / (8 κ B0 R_E³)``:
the orbit radius cancels, and ``λ_f`` grows with ``d²``
(:func:`magsail_mj.analysis.scaling.scaling_report`, also ``magsail scaling magnetorquer``).

**Current loop around the rim** (current-loops concept, geometry A). The conductor's own inertia
makes the needed mass fraction implicit, ``λ_f = λ_u (1 + κ λ_f)^{4/3}``: below the fold
``λ* = 3/κ`` there are two solutions (a light and a heavy branch) and beyond it none.
:func:`magsail_mj.analysis.loop_scaling.trace_branches_A` traces both by their parameter.
"""

import matplotlib.pyplot as plt
import numpy as np

from magsail_mj.analysis.loop_scaling import fold_A, trace_branches_A
from magsail_mj.analysis.scaling import scaling_report

ALTITUDE_KM = 800.0
side_m = np.logspace(0.5, 3.5, 60)
kappas = [10.0, 30.0, 100.0, 300.0]
report = scaling_report(side_m.tolist(), kappas, altitude_km=ALTITUDE_KM)
for kappa, d_one in zip(kappas, report["d_at_lambda_f_1_m"]):
    print(f"κ = {kappa:5g} A·m²/kg: all mass in rods (λ_f = 1) at d = {d_one:7.1f} m")

fig, ax = plt.subplots(figsize=(7, 4.5))
for kappa, row in zip(kappas, report["lambda_f"]):
    ax.loglog(side_m, row, label=f"κ = {kappa:g} A·m²/kg")
ax.axhline(1.0, color="k", lw=0.8, ls=":", label="λ_f = 1 (all mass in rods)")
ax.axhline(0.5, color="0.5", lw=0.8, ls="--", label="λ_f = 0.5 (the truss's design)")
ax.set_xlabel("plate side d [m]")
ax.set_ylabel("rod mass fraction λ_f [-]")
ax.set_title("magnetorquer rods against gravity gradient (any circular orbit)", fontsize=10)
ax.grid(True, which="both", alpha=0.25)
ax.legend(fontsize=8)

# %%
# The rim loop: two branches and a fold
# -------------------------------------
# Solid: the light branch; dashed: the heavy branch; circle: the fold ``λ* = 3/κ``; star: ``λ_f = 1``.
# With ``κ = 15`` (the paper's rim-inertia factor) the fold is at ``λ_f = 0.2``.

KAPPA_RIM = 15.0
lam_star = fold_A(KAPPA_RIM)[0]
fig, ax = plt.subplots(figsize=(7, 4.5))
for k, sigma_g_m2 in enumerate([1.0, 10.0, 100.0]):
    lam = np.unique(np.append(np.logspace(-10, 0, 400), lam_star))
    branch = trace_branches_A(sigma_g_m2 * 1e-3, kappa=KAPPA_RIM, lambdas=lam)
    heavy = branch["heavy"]
    colour = f"C{k}"
    light_idx = np.flatnonzero(~heavy)
    heavy_idx = np.concatenate([light_idx[-1:], np.flatnonzero(heavy)])
    ax.loglog(
        branch["side_m"][light_idx],
        branch["lambda_f"][light_idx],
        "-",
        color=colour,
        label=f"σ_A = {sigma_g_m2:g} g/m²",
    )
    ax.loglog(branch["side_m"][heavy_idx], branch["lambda_f"][heavy_idx], "--", color=colour)
    i_fold = int(np.argmin(np.abs(branch["lambda_f"] - lam_star)))
    ax.plot(branch["side_m"][i_fold], branch["lambda_f"][i_fold], "o", mfc="white", color=colour)
    i_one = int(np.argmin(np.abs(branch["lambda_f"] - 1.0)))
    ax.plot(branch["side_m"][i_one], branch["lambda_f"][i_one], "*", ms=10, color=colour)
    print(f"σ_A = {sigma_g_m2:g} g/m²: largest plate (the fold) D = {branch['side_m'][i_fold]:.0f} m")
ax.set_xlim(10.0, 1e5)
ax.set_ylim(1e-6, 2.0)
ax.set_xlabel("plate side D [m]")
ax.set_ylabel("conductor mass fraction λ_f [-]")
ax.set_title(f"geometry A (perimeter loop), κ = {KAPPA_RIM:g}: light (solid) and heavy (dashed) branch", fontsize=10)
ax.grid(True, which="both", alpha=0.25)
ax.legend(fontsize=8, loc="lower right")
plt.show()
