r"""Probes and metrics of the current-loops runs (current-loops spec §4.6, §5, §6, §7.2).

Flexible runs record the node positions (every ``record_every`` steps), the kinetic energy and
the work ledger (Lorentz work and damping work, exact for forces held over a step). From them:

* strain energy ``U(t) = Σ ½ k (|r_j − r_i| − L)²``;
* best-fit rotation ``R_θ(t)`` (Kabsch, uniform masses) and its angle; body-frame displacement
  ``u = R_θᵀ(r − c) − (r₀ − c₀)``; thickness ``h = max z_b − min z_b``; rigid-fit residual
  ``ρ = √mean|u|²``; largest strut strain;
* modal amplitudes ``q_n = φ_nᵀ M u`` of the first elastic modes, normalised by their overall max;
* angle between the circuits' dipole axis (body) and the field;
* energy balance ``E_kin + U − W_Lorentz − W_damping`` relative to the largest ``|W_Lorentz|``;
* the rigid-body reference (:mod:`magsail_mj.analysis.rigid_reference`) with the realised
  dipole, its rotation angle and the flexible run's largest deviation from it;
* classification (§4.6, thresholds in ``[classification]``): *collapsed* if ρ_max > 0.1 D, or
  the largest strain > 0.5, or h_max > 5 w; *rigid_like* if ρ_max < 0.005 D and the rotation
  stays within 3° of the rigid reference; otherwise *flexible*.

Slews add the attitude error ``2 arccos|q_e,w|``, currents, saturation, commanded and achieved
dipole, magnetic and gravity-gradient torques about the centre of mass.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from magsail_mj.estimation.attitude import BestFitRotation, rotation_angle

__all__ = ["probes", "postprocess", "first_time_below", "structural_series"]

N_MODAL = 10


def probes(sc) -> dict[str, Any]:
    """Recorder probes of a current-loops scenario."""
    out: dict[str, Any] = {}
    if sc.rigid:
        out["qpos"] = lambda s, d: d.qpos
        out["qvel"] = lambda s, d: d.qvel
    else:
        nb = sc.node_bodies
        m = sc.lm.masses
        out["qpos"] = lambda s, d: d.qpos
        out["kinetic_energy_J"] = lambda s, d: 0.5 * float(m @ np.einsum("ij,ij->i", s.vel[nb], s.vel[nb]))
        if sc.ledger is not None:
            led = sc.ledger
            out["work_J"] = lambda s, d: led.values(s.pos)
    if sc.cfg.scenario != "sweep":
        out["currents_A"] = lambda s, d: s.ctrl.currents_A if s.ctrl is not None else np.zeros(3)
        out["currents_axis_A"] = lambda s, d: s.ctrl.currents_axis_A if s.ctrl is not None else np.zeros(3)
        out["saturated"] = lambda s, d: s.ctrl.saturated if s.ctrl is not None else np.zeros(3, bool)
        out["q"] = lambda s, d: s.ctrl.q if s.ctrl is not None else np.array([1.0, 0, 0, 0])
        out["q_err"] = lambda s, d: s.ctrl.q_err if s.ctrl is not None else np.array([1.0, 0, 0, 0])
        out["omega_body_rad_s"] = lambda s, d: s.ctrl.omega_body if s.ctrl is not None else np.zeros(3)
        out["torque_ref_body_Nm"] = lambda s, d: s.ctrl.torque_ref_body if s.ctrl is not None else np.zeros(3)
        out["dipole_cmd_body_Am2"] = lambda s, d: s.ctrl.dipole_cmd_body if s.ctrl is not None else np.zeros(3)
        out["B_body_T"] = lambda s, d: s.ctrl.B_body if s.ctrl is not None else np.zeros(3)
        out["torques_world_Nm"] = _torque_probe(sc)
    return out


def _torque_probe(sc):
    """(2, 3): magnetic and gravity-gradient torque about the CM (world axes) at this state."""
    if sc.rigid:
        def probe(s, d):
            mag = sc.rigid_torque.last_torque if s.ctrl is not None else np.zeros(3)
            gg = sc.gg_load.torque_world(s) if sc.gg_load is not None else np.zeros(3)
            if s.ctrl is not None:
                from magsail_mj.estimation.attitude import matrix_from_quat

                R = matrix_from_quat(s.xquat[1])
                B = sc.field_fixed if sc.field_fixed is not None else s.env.B_eci
                mag = np.cross(R @ (np.asarray(s.ctrl.currents_A) @ sc.areas0), B)
            return np.stack([mag, gg])
        return probe

    from magsail_mj.loads.lorentz import lorentz_node_forces

    nb, m = sc.node_bodies, sc.lm.masses

    def probe(s, d):
        x = s.pos[nb]
        c = (m @ x) / m.sum()
        r = x - c
        mag = np.zeros(3)
        if s.ctrl is not None:
            B = sc.lorentz.field(s)
            mag = np.cross(r, lorentz_node_forces(x, sc.segments, s.ctrl.currents_A, B)).sum(axis=0)
        gg = np.zeros(3)
        if sc.tidal is not None:
            a = sc.tidal.accelerations(np.asarray(s.env.r_ref_eci), x)
            gg = np.cross(r, m[:, None] * a).sum(axis=0)
        return np.stack([mag, gg])

    return probe


def first_time_below(t: np.ndarray, x: np.ndarray, level: float) -> float | None:
    """First time ``x`` is below ``level`` (``None`` if never)."""
    idx = np.flatnonzero(x < level)
    return float(t[idx[0]]) if idx.size else None


def structural_series(sc, x: np.ndarray) -> dict[str, np.ndarray]:
    """Strain energy, best fit, thickness, residual, strain and modal amplitudes of positions ``x``
    (T, n, 3)."""
    lat = sc.lm.lattice
    p0 = lat.nodes
    R, dvec = BestFitRotation(p0)(x)
    c = x.mean(axis=1)
    xb = np.einsum("tji,tnj->tni", R, x - c[:, None, :])        # R^T (x - c)
    u = xb - (p0 - p0.mean(axis=0))
    a, b = lat.struts[:, 0], lat.struts[:, 1]
    L = np.linalg.norm(x[:, b] - x[:, a], axis=2)
    dL = L - lat.rest_length
    U = 0.5 * (sc.lm.k * dL**2).sum(axis=1)
    out = {
        "strain_energy_J": U,
        "rotation_angle_rad": rotation_angle(R),
        "R_bestfit": R,
        "thickness_m": xb[:, :, 2].max(axis=1) - xb[:, :, 2].min(axis=1),
        "rigid_fit_residual_m": np.sqrt((u**2).sum(axis=2).mean(axis=1)),
        "strut_strain_max": np.abs(dL / lat.rest_length).max(axis=1),
    }
    try:
        md = sc.modes()
        sl = md.elastic
        phi = md.phi[:, sl.start:sl.start + N_MODAL]
        q = (u.reshape(u.shape[0], -1) * md.mass_diag) @ phi
        out["modal_amplitude"] = q / max(np.abs(q).max(), 1e-300)
        out["modal_omega_rad_s"] = md.omega[sl.start:sl.start + N_MODAL]
    except Exception:  # noqa: BLE001 - modes are a diagnostic; never lose a run for them
        pass
    return out


def _node_positions(sc, qpos: np.ndarray) -> np.ndarray:
    from magsail_mj.mjcf.truss import node_positions_from_qpos

    return node_positions_from_qpos(sc.model, qpos, n_nodes=sc.lm.lattice.n_nodes)


def _at(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    i = int(np.argmax(y))
    return float(y[i]), float(t[i])


def postprocess(sc, result) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    cfg = sc.cfg
    rec = result.records
    t = rec["t"]
    summary: dict[str, Any] = {"status": result.status, "status_message": result.message,
                               "t_end_s": result.t_end_s, "wall_time_s": result.wall_time_s}
    series: dict[str, np.ndarray] = {}
    if len(t) == 0:
        return summary, series
    if cfg.scenario == "sweep":
        s, ser = _sweep_metrics(sc, rec)
    else:
        s, ser = _slew_metrics(sc, rec)
    summary.update(s)
    series.update(ser)
    return summary, series


def _classify(sc, rho_max: float, strain_max: float, h_max: float, dev_max: float) -> str:
    c = sc.cfg.classification
    D = sc.cfg.lattice.side_m
    w = D / sc.cfg.lattice.units
    if (rho_max > c.collapse_residual_frac * D or strain_max > c.collapse_strain
            or h_max > c.collapse_thickness_units * w):
        return "collapsed"
    if rho_max < c.rigid_residual_frac * D and dev_max <= np.radians(c.rigid_angle_tol_deg):
        return "rigid_like"
    return "flexible"


def _sweep_metrics(sc, rec) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    from magsail_mj.analysis.rigid_reference import rigid_dipole_attitude
    from magsail_mj.loads.lorentz import self_field_max_T

    cfg, lat = sc.cfg, sc.lm.lattice
    t = rec["t"]
    x = _node_positions(sc, rec["qpos"])
    st = structural_series(sc, x)
    U = st["strain_energy_J"]
    B = sc.field_fixed
    I = sc.lm.currents_A
    m_body = I @ sc.areas0
    # rigid reference with the realised dipole
    R_rig, _ = rigid_dipole_attitude(t, inertia=sc.inertia.tensor, dipole_body=m_body, field_world=B)
    ang_rig = rotation_angle(R_rig)
    ang = st["rotation_angle_rad"]
    dev = rotation_angle(st["R_bestfit"], relative_to=R_rig)
    # dipole–field angle: realised dipole direction in the world
    m_world = np.einsum("tij,j->ti", st["R_bestfit"], m_body)
    cosang = m_world @ B / (np.linalg.norm(m_world, axis=1) * np.linalg.norm(B))
    dip_field = np.arccos(np.clip(cosang, -1, 1))
    U_max, t_U = _at(t, U)
    iU = int(np.argmax(U))
    ke = rec["kinetic_energy_J"]
    work = rec.get("work_J")
    names = list(sc.ledger.watched) if sc.ledger is not None else []
    W_L = work[:, names.index("lorentz")] if work is not None and "lorentz" in names else np.zeros_like(t)
    W_D = work[:, names.index("damping")] if work is not None and "damping" in names else np.zeros_like(t)
    residual = ke + U - W_L - W_D
    scale = max(np.abs(W_L).max(), 1e-300)
    rho_max = float(st["rigid_fit_residual_m"].max())
    strain_max = float(st["strut_strain_max"].max())
    h_max = float(st["thickness_m"].max())
    dev_max = float(dev.max())
    summary = {
        "current_A": float(I[0]) if I.size == 1 else [float(v) for v in I],
        "dipole_realised_A_m2": float(np.linalg.norm(m_body)),
        "strain_energy_max_J": U_max,
        "t_strain_energy_max_s": t_U,
        "thickness_max_m": h_max,
        "rigid_fit_residual_max_m": rho_max,
        "strut_strain_max": strain_max,
        "rotation_angle_max_rad": float(ang.max()),
        "rotation_angle_final_rad": float(ang[-1]),
        "rigid_rotation_angle_final_rad": float(ang_rig[-1]),
        "rotation_dev_from_rigid_max_rad": dev_max,
        "dipole_field_angle_at_Umax_rad": float(dip_field[iU]),
        "energy_balance_rel_err": float(np.abs(residual).max() / scale),
        "lorentz_work_final_J": float(W_L[-1]),
        "damping_work_final_J": float(W_D[-1]),
        "stability_product_max": (sc.damping_info()["stability_product_max"] if cfg.damping.enabled else 0.0),
        "self_field_max_T": float(self_field_max_T(lat.nodes, sc.segments, I)),
        "classification": _classify(sc, rho_max, strain_max, h_max, dev_max),
    }
    series = {k: v for k, v in st.items() if k != "R_bestfit"}
    series.update(rotation_angle_deg=np.degrees(ang), rigid_rotation_angle_rad=ang_rig,
                  rotation_dev_from_rigid_rad=dev, dipole_field_angle_rad=dip_field,
                  energy_residual_J=residual, lorentz_work_J=W_L, damping_work_J=W_D,
                  dipole_world_Am2=m_world, snapshot_index=np.array(iU))
    return summary, series


def _slew_metrics(sc, rec) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    t = rec["t"]
    qe = rec["q_err"]
    err = 2.0 * np.arccos(np.clip(np.abs(qe[:, 0]), 0.0, 1.0))
    t5 = first_time_below(t, err, np.radians(5.0))
    t2 = first_time_below(t, err, np.radians(2.0))
    after = t >= t5 if t5 is not None else np.zeros_like(t, dtype=bool)
    if np.any(after):
        i = np.flatnonzero(after)[np.argmax(err[after])]
        err_after, t_err_after = float(err[i]), float(t[i])
    else:
        err_after, t_err_after = None, None
    sat = rec["saturated"].astype(bool)
    torques = rec["torques_world_Nm"]
    mag = np.linalg.norm(torques[:, 0], axis=1)
    gg = np.linalg.norm(torques[:, 1], axis=1)
    I = rec["currents_axis_A"]
    m_ach = np.einsum("tl,lj->tj", rec["currents_A"], sc.areas0)
    summary: dict[str, Any] = {
        "t_err_below_5deg_s": t5, "t_err_below_2deg_s": t2,
        "err_max_after_settle_rad": err_after, "t_err_max_after_settle_s": t_err_after,
        "err_final_rad": float(err[-1]),
        "saturation_fraction": float(np.mean(np.any(sat, axis=1))),
        "mag_torque_max_N_m": float(mag.max()), "gg_torque_max_N_m": float(gg.max()),
        # issue #5 item 6 names
        "time_to_target_s": t5,
        "attitude_error_max_after_target_deg": None if err_after is None else float(np.degrees(err_after)),
        "current_max_A": [float(v) for v in np.abs(I).max(axis=0)],
    }
    series = {"error_angle_rad": err, "error_angle_deg": np.degrees(err), "mag_torque_world_Nm": torques[:, 0],
              "gg_torque_world_Nm": torques[:, 1], "dipole_achieved_body_Am2": m_ach}
    from magsail_mj.estimation.attitude import euler_zyx, matrix_from_quat

    try:
        eul = euler_zyx(matrix_from_quat(rec["q"]))
        series["euler_zyx_rad"] = np.stack(eul, axis=-1) if isinstance(eul, tuple) else eul
    except Exception:  # noqa: BLE001 - a plotting aid only
        pass
    if not sc.rigid:
        x = _node_positions(sc, rec["qpos"])
        st = structural_series(sc, x)
        U = st["strain_energy_J"]
        U_max, t_U = _at(t, U)
        summary.update(strain_energy_max_J=U_max, t_strain_energy_max_s=t_U, time_strain_max_s=t_U,
                       rigid_fit_residual_max_m=float(st["rigid_fit_residual_m"].max()),
                       strut_strain_max=float(st["strut_strain_max"].max()),
                       thickness_max_m=float(st["thickness_m"].max()))
        series.update({k: v for k, v in st.items() if k != "R_bestfit"})
        series["snapshot_index"] = np.array(int(np.argmax(U)))
    return summary, series
