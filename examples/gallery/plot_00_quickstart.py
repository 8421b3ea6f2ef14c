"""
Quick start: load, step, save and restore the state
===================================================

:func:`magsail_mj.load` turns a config file (plus ``--set``-style overrides) into a simulation with
``step(n)`` (n physics steps), ``run()``, ``get_state()`` / ``set_state(state)``, ``time`` [s], the
MuJoCo ``model`` and ``data``, and ``records()`` (the time series recorded so far).

The spacecraft here is the sail-carrying cubesat, tumbling at ω₀ = (6, −7, 3) °/s in its stowed
configuration; its magnetorquers run the B-dot law ``m = −K dB/dt`` [A·m²]. The example runs
120 s (the paper's detumble takes 10 orbits), saves the state at 60 s, and checks that continuing
from the restored state repeats the same steps bit for bit.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import magsail_mj

# the repository root: the nearest folder from here upwards that holds models/ (the docs build
# runs this script in examples/gallery, a reader from the root)
ROOT = next(folder for folder in (Path.cwd(), *Path.cwd().parents) if (folder / "magsail_mj" / "concepts").is_dir())
sim = magsail_mj.load(
    ROOT / "magsail_mj" / "concepts" / "cnusail" / "configs" / "detumble_pre.toml", ["sim.duration_s=120"]
)  # noqa: E501
steps_per_minute = round(60.0 / sim.model.opt.timestep)
sim.step(steps_per_minute)  # 0 → 60 s
saved = sim.get_state()  # plain arrays and scalars
sim.step(steps_per_minute)  # 60 → 120 s
first_qpos = sim.data.qpos.copy()

sim.set_state(saved)  # back to 60 s (records after it are dropped)
sim.step(steps_per_minute)  # 60 → 120 s again
assert np.array_equal(sim.data.qpos, first_qpos)
print(
    f"t = {sim.time:g} s; the restored run repeats the first bit for bit: {np.array_equal(sim.data.qpos, first_qpos)}"
)

# %%
# The recorded body rate
# ----------------------
# ``records()`` holds ``t`` [s] and every probe; ``qvel[:, 3:6]`` is the bus's angular velocity
# in body axes [rad/s].

records = sim.records()
t_s = np.asarray(records["t"])
omega_deg_s = np.degrees(np.asarray(records["qvel"])[:, 3:6])
fig, ax = plt.subplots(figsize=(7, 4.4), layout="constrained")
for k, axis in enumerate("xyz"):
    ax.plot(t_s, omega_deg_s[:, k], label=f"ω_{axis}")
ax.plot(t_s, np.linalg.norm(omega_deg_s, axis=1), "k--", label="|ω|")
ax.axvline(60.0, color="0.5", lw=0.8, ls=":", label="state saved and restored")
ax.set_xlabel("time [s]")
ax.set_ylabel("body rate [°/s]")
ax.set_title(
    "CNUSAIL stowed, B-dot detumble: first 120 s (magsail_mj/concepts/cnusail/configs/detumble_pre.toml)", fontsize=10
)  # noqa: E501
ax.grid(alpha=0.3)
fig.legend(fontsize=8, ncol=5, loc="outside lower center")
plt.show()
