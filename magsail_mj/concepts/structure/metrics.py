r"""Metrics of the ``structure`` concept: what each record holds and the run's summary.

Per record (:class:`StructureMonitor`, from the state the probes see; node positions ``x_i`` from
the body poses):

* **best-fit attitude** ``R`` and **shape deviation**: the least-squares rigid fit (Kabsch) of
  ``x_i`` to the reference positions ``p_i``, ``min Σ |x_i − (R p_i + d)|²`` (nodes on one line leave
  the rotation about that line undefined: ``R`` is then the SVD's choice and the rate about the
  line is not measured, the deviation is still the least one, :func:`rigid_fit`); the deviation of node
  ``i`` is ``e_i = x_i − (R p_i + d)``, recorded as ``shape_rms_m = √(Σ|e_i|²/n)`` and
  ``shape_max_m = max |e_i|`` (for a flat plate ``shape_rms_m`` generalises the truss's surface
  deviation σ_SD to the whole structure, in-plane included);
* **member strains** ``ε_j = l_j / l0_j − 1`` (``l_j`` the end nodes' distance): the largest
  ``|ε_j|`` (a slack cable counts 0) and its member; the run fails (status ``structure_failed``)
  when a member passes ``min(strain_limit_j, sim.max_strain)``;
* **strain energy** of the model's springs, ``Σ ½ k_j (l_j − l0_j)²`` over struts and cables (a
  cable only when taut) plus ``Σ ½ k (q − q_ref)²`` over the beams' axial, twist and bending
  joints (MuJoCo's own spring potential);
* **angular momentum** ``H`` about the centre of mass, world axes (MuJoCo's ``subtree_angmom`` of
  the world body, from a scratch copy of ``qpos``, ``qvel``).

Post-processing (:func:`structure_summary`): the body rate from consecutive best-fit rotations,
``ω_k = vee(log(R_{k−1}ᵀ R_k)) / (t_k − t_{k−1})`` (the initial rate at ``t = 0``), its norm over
time, the largest and final shape deviation, strain and strain energy, the angular momentum's
drift; :func:`actuator_keys`, :func:`detumble_keys` and :func:`slew_keys` add the actuated scenarios'
figures, :func:`panel_keys` those of the panels' solar pressure and drag.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from magsail_mj.concepts.structure.model import StructureModel
from magsail_mj.concepts.structure.source import collinear
from magsail_mj.divergence import StructureFailure
from magsail_mj.estimation.attitude import BestFitRotation, body_rates
from magsail_mj.quaternion import error_quaternion, quat_from_matrix
from magsail_mj.structure.model import MEMBER_KINDS

__all__ = [
    "StructureMonitor",
    "rigid_fit",
    "first_time_below",
    "stay_time_below",
    "structure_summary",
    "actuator_keys",
    "panel_keys",
    "detumble_keys",
    "slew_keys",
]

_BEAM = MEMBER_KINDS.index("beam")
_CABLE = MEMBER_KINDS.index("cable")


class _LineFit:
    """The Kabsch fit of a collinear reference (module docstring): the SVD's rotation, no refusal."""

    def __init__(self, p_ref: np.ndarray) -> None:
        self.p_bar = np.asarray(p_ref, dtype=float).mean(axis=0)
        self.pc = np.asarray(p_ref, dtype=float) - self.p_bar

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q_bar = q.mean(axis=0)
        U, _, Vt = np.linalg.svd(self.pc.T @ (q - q_bar))
        if np.linalg.det(Vt.T @ U.T) < 0:
            Vt[2] *= -1.0
        R = Vt.T @ U.T
        return R, q_bar - R @ self.p_bar


def rigid_fit(reference_m: np.ndarray) -> BestFitRotation | _LineFit:
    """The least-squares rigid fit to ``reference_m``: ``fit(x) → (R, d)`` with ``x ≈ R p + d``."""
    return _LineFit(reference_m) if collinear(reference_m) else BestFitRotation(reference_m)


def first_time_below(t: np.ndarray, x: np.ndarray, threshold: float) -> float:
    """The first sample time with ``x ≤ threshold`` [s]; NaN when there is none."""
    idx = np.flatnonzero(np.asarray(x) <= threshold)
    return float(t[idx[0]]) if idx.size else float("nan")


def stay_time_below(t: np.ndarray, x: np.ndarray, threshold: float) -> float:
    """The first sample time from which ``x`` stays ``≤ threshold`` to the end [s]: ``t[0]`` when
    it never exceeds it, NaN when the last sample is above it."""
    above = np.flatnonzero(~(np.asarray(x) <= threshold))
    if not above.size:
        return float(t[0]) if len(t) else float("nan")
    k = above[-1] + 1
    return float(t[k]) if k < len(t) else float("nan")


class StructureMonitor:
    """The per-record quantities of the module docstring, computed once per record and shared by
    the probes, and the strain check of the runner.

    Args:
      sm: the structure's model.
      max_strain: ``sim.max_strain``, the bound on every member's strain besides its own limit.
    """

    #: the probes that read it, and the record each returns
    PROBES = (
        "R_fit",
        "shape_rms_m",
        "shape_max_m",
        "member_strain_max",
        "member_strain_max_index",
        "strain_energy_J",
        "angmom_world_Nms",
    )

    def __init__(self, sm: StructureModel, *, max_strain: float) -> None:
        structure, model = sm.structure, sm.model
        members = structure.members
        self.nodes = sm.nodes
        self.fit = rigid_fit(structure.positions_m)
        self.reference_m = np.asarray(structure.positions_m, dtype=float)
        self.ends = np.asarray(members.nodes, dtype=np.int64)
        self.rest_m = np.asarray(members.rest_length_m, dtype=float)
        self.cable = members.kind == _CABLE
        self.limit = np.minimum(members.strain_limit, float(max_strain))
        tendon = members.kind != _BEAM
        self.k_tendon = np.where(tendon, members.stiffness_N_m, 0.0)
        joints = sm.index.beam_qposadr[members.kind == _BEAM].reshape(-1)
        jnt_of_qpos = np.full(model.nq, -1, dtype=np.int64)
        jnt_of_qpos[model.jnt_qposadr] = np.arange(model.njnt)
        self.beam_qpos = joints
        self.beam_k = model.jnt_stiffness[jnt_of_qpos[joints]] if joints.size else np.zeros(0)
        self.beam_ref = model.qpos_spring[joints] if joints.size else np.zeros(0)
        self.model = model
        self.scratch = mujoco.MjData(model)
        self.values: dict[str, Any] = {}
        self.t_sampled = -math.inf

    # ------------------------------------------------------------------ one state
    def node_positions(self, state: Any) -> np.ndarray:
        """(n, 3) world node positions [m] of ``state``."""
        return self.nodes.positions(state.pos, state.xquat)

    def strains(self, x: np.ndarray) -> np.ndarray:
        """(m,) member strains ``l/l0 − 1`` at node positions ``x``."""
        d = x[self.ends[:, 1]] - x[self.ends[:, 0]]
        return np.sqrt(np.einsum("ij,ij->i", d, d)) / self.rest_m - 1.0

    def strain_energy(self, strain: np.ndarray, qpos: np.ndarray) -> float:
        """The springs' potential [J] (module docstring) from the strains and ``qpos``."""
        stretch = strain * self.rest_m
        stretch = np.where(self.cable, np.maximum(stretch, 0.0), stretch)
        energy = 0.5 * float(self.k_tendon @ (stretch * stretch))
        if self.beam_qpos.size:
            q = qpos[self.beam_qpos] - self.beam_ref
            energy += 0.5 * float(self.beam_k @ (q * q))
        return energy

    def angular_momentum(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) angular momentum about the centre of mass, world axes [N m s]."""
        s = self.scratch
        s.qpos[:] = data.qpos
        s.qvel[:] = data.qvel
        mujoco.mj_kinematics(self.model, s)
        mujoco.mj_comPos(self.model, s)
        mujoco.mj_comVel(self.model, s)
        mujoco.mj_subtreeVel(self.model, s)
        return s.subtree_angmom[0].copy()

    def sample(self, state: Any, data: mujoco.MjData) -> dict[str, Any]:
        """Every per-record value of ``state`` (computed once per record time)."""
        if state.t == self.t_sampled:
            return self.values
        x = self.node_positions(state)
        R, d = self.fit(x)
        e = x - (self.reference_m @ R.T + d)
        dev = np.sqrt(np.einsum("ij,ij->i", e, e))
        strain = self.strains(x)
        counted = np.where(self.cable, np.maximum(strain, 0.0), np.abs(strain))
        j = int(np.argmax(counted)) if counted.size else -1
        ratio = counted / self.limit
        worst = int(np.argmax(ratio)) if ratio.size else -1
        self.values = {
            "R_fit": R,
            "shape_rms_m": float(np.sqrt(np.mean(dev * dev))),
            "shape_max_m": float(dev.max()),
            "member_strain_max": float(counted[j]) if j >= 0 else 0.0,
            "member_strain_max_index": np.int64(j),
            "strain_energy_J": self.strain_energy(strain, data.qpos),
            "angmom_world_Nms": self.angular_momentum(data),
            "_failed": None if worst < 0 or ratio[worst] <= 1.0 else (worst, float(counted[worst]), float(state.t)),
        }
        self.t_sampled = float(state.t)
        return self.values

    def probes(self) -> dict[str, Any]:
        """The recorder's probes of :attr:`PROBES`."""
        return {name: (lambda s, d, name=name: self.sample(s, d)[name]) for name in self.PROBES}

    def strain_check(self, positions: Any) -> tuple[float, int]:
        """The runner's strain check (after the record of the state is written): raise
        :class:`~magsail_mj.divergence.StructureFailure` naming the member, its strain, its limit and
        the time when a member passed its limit; else ``(largest strain, its member)``."""
        failed = self.values.get("_failed")
        if failed is not None:
            j, strain, t = failed
            raise StructureFailure(
                f"member {j} strain {strain:.3g} exceeds its strain limit {self.limit[j]:g} at t = {t:.6g} s"
            )
        return self.values.get("member_strain_max", 0.0), int(self.values.get("member_strain_max_index", -1))


# =========================================================================== post-processing


def rates_from_fit(t: np.ndarray, R: np.ndarray, *, omega0_body: np.ndarray) -> np.ndarray:
    """(T, 3) body rates [rad/s] from the recorded best-fit rotations ``R`` (T, 3, 3) at ``t``."""
    if len(t) < 2:
        return np.tile(np.asarray(omega0_body, dtype=float), (len(t), 1))
    return body_rates(R, np.diff(t), method="log", omega0=np.asarray(omega0_body, dtype=float))


def structure_summary(
    sm: StructureModel, records: Any, *, omega0_body: np.ndarray
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Keys and series every scenario has (module docstring)."""
    t = np.asarray(records["t"], dtype=float)
    R = np.asarray(records["R_fit"], dtype=float)
    omega = rates_from_fit(t, R, omega0_body=omega0_body)
    w = np.linalg.norm(omega, axis=1)
    H = np.asarray(records["angmom_world_Nms"], dtype=float)
    H_norm = np.linalg.norm(H, axis=1)
    rms, dev_max = np.asarray(records["shape_rms_m"]), np.asarray(records["shape_max_m"])
    strain, energy = np.asarray(records["member_strain_max"]), np.asarray(records["strain_energy_J"])
    k = int(np.argmax(strain))
    s = sm.structure
    moments = np.linalg.eigvalsh(sm.inertia_kg_m2)
    H0 = float(H_norm[0]) if H_norm[0] > 0 else float("nan")
    keys = {
        "n_nodes": s.n_nodes,
        "n_members": s.n_members,
        "n_panels": len(s.panels),
        "n_rigid_parts": len(s.rigid_parts),
        "n_dofs": int(sm.model.nv),
        "total_mass_kg": sm.total_mass_kg,
        "I_principal_kgm2": moments.tolist(),
        "omega_norm_initial_rad_s": float(w[0]),
        "omega_norm_final_rad_s": float(w[-1]),
        "omega_norm_max_rad_s": float(w.max()),
        "omega_final_rad_s": omega[-1].tolist(),
        "angmom_initial_Nms": float(H_norm[0]),
        "angmom_final_Nms": float(H_norm[-1]),
        "angmom_change_rel": float(np.max(np.linalg.norm(H - H[0], axis=1)) / H0),
        "shape_rms_max_m": float(rms.max()),
        "shape_rms_final_m": float(rms[-1]),
        "shape_max_max_m": float(dev_max.max()),
        "member_strain_max": float(strain[k]),
        "member_strain_max_member": int(np.asarray(records["member_strain_max_index"])[k]),
        "t_member_strain_max_s": float(t[k]),
        "strain_energy_max_J": float(energy.max()),
        "strain_energy_final_J": float(energy[-1]),
    }
    series = {"omega_body_rad_s": omega, "omega_norm_rad_s": w, "angmom_norm_Nms": H_norm}
    return keys, series


def actuator_keys(records: Any) -> dict[str, Any]:
    """The actuators' figures: control samples, the share of saturated samples, the largest
    reference and allocated torques [N m], and the largest torque the rods and the loops deliver on
    the deformed structure [N m] and the loops' largest current [A] (for those present)."""
    counts = np.asarray(records["control_counts"])[-1].astype(float)

    def largest(name: str) -> float:
        return float(np.linalg.norm(np.asarray(records[name], dtype=float), axis=1).max())

    keys = {
        "control_samples": int(counts[0]),
        "saturation_fraction": float(counts[1] / max(counts[0], 1.0)),
        "torque_ref_max_Nm": largest("torque_ref_body_Nm"),
        "torque_alloc_max_Nm": largest("torque_alloc_body_Nm"),
    }
    if "torque_rod_body_Nm" in records:
        keys["torque_rod_max_Nm"] = largest("torque_rod_body_Nm")
    if "torque_loop_body_Nm" in records:
        keys["torque_loop_max_Nm"] = largest("torque_loop_body_Nm")
        keys["loop_current_max_A"] = float(np.max(np.abs(np.asarray(records["loop_currents_A"], dtype=float))))
    return keys


def panel_keys(records: Any) -> dict[str, Any]:
    """The panels' figures, for the loads that are on: the largest net SRP and drag force [N] and
    moment about the centre of mass [N m] (``srp_force_max_N``, ``srp_torque_max_Nm``, and
    ``drag_…``; none when neither load is on)."""
    keys: dict[str, Any] = {}
    for name in ("srp", "drag"):
        if f"{name}_wrench_world" not in records:
            continue
        w = np.asarray(records[f"{name}_wrench_world"], dtype=float)
        keys[f"{name}_force_max_N"] = float(np.linalg.norm(w[:, :3], axis=1).max())
        keys[f"{name}_torque_max_Nm"] = float(np.linalg.norm(w[:, 3:], axis=1).max())
    return keys


def detumble_keys(t: np.ndarray, omega_norm: np.ndarray, *, threshold_rad_s: float) -> dict[str, Any]:
    """Detumble figures: when ``|ω|`` first falls, and when it falls to stay, below ``threshold_rad_s``."""
    return {
        "rate_threshold_rad_s": threshold_rad_s,
        "t_rate_below_threshold_first_s": first_time_below(t, omega_norm, threshold_rad_s),
        "t_rate_below_threshold_stay_s": stay_time_below(t, omega_norm, threshold_rad_s),
    }


def slew_keys(t: np.ndarray, R: np.ndarray, *, q0_wxyz: Any, q_ref_wxyz: Any) -> tuple[dict[str, Any], np.ndarray]:
    """Slew figures of the best-fit attitude ``R`` (T, 3, 3): the error angle
    ``2 atan2(|q_e,vec|, q_e,0)`` of ``q_e = q_ref* ⊗ q`` [rad] over time, its initial and final
    values and when it first falls and stays below 5° and 2°. Returns ``(keys, error angle series)``."""
    q_ref = np.asarray(q_ref_wxyz, dtype=float)
    q_ref = q_ref / np.linalg.norm(q_ref)
    q_e = error_quaternion(q_ref, quat_from_matrix(R))
    err = 2.0 * np.arctan2(np.linalg.norm(q_e[:, 1:], axis=1), q_e[:, 0])
    q0 = np.asarray(q0_wxyz, dtype=float)
    q_s = error_quaternion(q_ref, q0 / np.linalg.norm(q0))
    d5, d2 = math.radians(5.0), math.radians(2.0)
    keys = {
        "slew_angle_deg": math.degrees(2.0 * math.atan2(float(np.linalg.norm(q_s[1:])), float(q_s[0]))),
        "error_initial_deg": math.degrees(float(err[0])),
        "error_final_deg": math.degrees(float(err[-1])),
        "t_error_below_5deg_first_s": first_time_below(t, err, d5),
        "t_error_below_5deg_stay_s": stay_time_below(t, err, d5),
        "t_error_below_2deg_stay_s": stay_time_below(t, err, d2),
    }
    return keys, err
