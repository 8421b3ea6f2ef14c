r"""Undamped linear modal bound on the surface deformation (SD) of a finished truss run.

The truss papers' 75 m detumble reports a surface SD well above the one our simulation gives. This
script asks how large the SD could get if the structure had no damping at all: it rebuilds the
control loads the run applied and integrates the lattice's elastic modes exactly
(:mod:`magsail_mj.lattice.forced_response`, zero damping, linearised about the undeformed lattice).

Loads (body frame of the undeformed lattice, the frame of the modes):

* the magnetorquer rods' force pairs ``F_j = −F_i = (s_r m_r / L)[B_b − (B_b·r̂) r̂]`` of every rod
  ``r`` in strut ``i → j`` (the ``actuators.force_pair`` variant of the run), with the recorded
  polarities ``s_r`` (``strut_activity``), the recorded field in body axes ``B_b``
  (``B_body_T``) and the undeformed strut direction ``r̂`` and length ``L``;
* with ``--force-pair``, another variant of the pair (e.g. the paper's printed form, which adds
  an axial strut load; the health check below always uses the run's own);
* with ``--centrifugal``, the centrifugal load ``m_i (|ω|² I − ω ωᵀ) p_i`` of the recorded body
  rate ``ω`` (``omega_est_body_rad_s``) about the centre of mass (the rigid angular acceleration's
  load has no elastic component). Gravity gradient and the deformed geometry are left out.

The records are 1 s apart while the rods switch every control step, so the load is held between
samples (``--hold zero``, default) or interpolated (``--hold linear``). The SD is the
population standard deviation of the top layer's distances to its total-least-squares plane
(:func:`magsail_mj.analysis.flatness.surface_sd`) of ``p + Φ q``.

Prints JSON: the simulated SD maximum and its time, the bound's maximum and time, their ratio,
the strain and total energy of every mode at the bound's maximum (the ten largest and the first
five), the dominant period of both SD series, and a health check (the rebuilt loads' torque
against the recorded ``torque_ac_body_Nm``).

    python scripts/truss_modal_upper_bound.py runs/truss_structure_gap/detumble/baseline
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from magsail_mj.analysis.flatness import surface_sd
from magsail_mj.concepts.truss_magnetorquer.force_pair import FORCE_PAIRS, pair_forces
from magsail_mj.concepts.truss_magnetorquer.model import make_truss_model
from magsail_mj.concepts.truss_magnetorquer.orbital import dominant_period
from magsail_mj.config import ConfigError, parse_config
from magsail_mj.lattice.forced_response import HOLDS, undamped_modal_response
from magsail_mj.lattice.modes import lattice_modes
from magsail_mj.loads.magnetorquer_rods import rod_array
from magsail_mj.records import RecordStoreError, lazy_arrays

N_TOP_MODES = 10
BLOCK = 500  # records per block when forming loads and displacements


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("run_dir", type=Path, help="finished truss run folder (read only)")
    p.add_argument("--hold", choices=HOLDS, default="zero", help="load between records (default: zero)")
    p.add_argument("--centrifugal", action="store_true", help="add the centrifugal load of the recorded body rate")
    p.add_argument(
        "--force-pair",
        choices=FORCE_PAIRS,
        default=None,
        help="rebuild the loads with this force-pair variant (default: the run's)",
    )
    p.add_argument("--out", type=Path, default=None, help="also write the JSON here")
    return p.parse_args(argv)


def rod_jacobian(lat, phi: np.ndarray, m_of_rod: np.ndarray, force_pair: str) -> tuple[np.ndarray, np.ndarray]:
    r"""Modal load per unit polarity and field: ``J`` (n_rods, 3, K) with
    ``f_n = Σ_r s_r Σ_c J[r, c, n] B_c`` [N kg^-1/2 / T] (the force pair is linear in ``s m`` and in
    ``B``), and the rods' strut indices. Built from the pair of each unit field axis."""
    rods = rod_array(lat)
    p = lat.nodes
    ri, rj = p[rods.ends[:, 0]], p[rods.ends[:, 1]]
    phi3 = phi.reshape(lat.n_nodes, 3, -1)
    dphi = phi3[rods.ends[:, 1]] - phi3[rods.ends[:, 0]]  # (R, 3, K): F_j = -F_i
    J = np.empty((rods.n_rods, 3, phi.shape[1]))
    for c in range(3):
        Fj = pair_forces(force_pair, ri, rj, m_of_rod, np.eye(3)[c])  # (R, 3)
        J[:, c, :] = np.einsum("rd,rdk->rk", Fj, dphi)
    return J, rods.struts


def centrifugal_basis(nodes: np.ndarray, masses: np.ndarray, phi: np.ndarray) -> np.ndarray:
    r"""``S`` (3, 3, K) with ``f_n = Σ_ab (|ω|² δ_ab − ω_a ω_b) S[a, b, n]`` for the centrifugal
    load ``m_i (|ω|² I − ω ωᵀ) p_i`` (``p_i`` about the centre of mass): ``S[a, b, n] = Σ_i m_i
    φ_n,i,a p_i,b``."""
    p = nodes - masses @ nodes / masses.sum()
    phi3 = phi.reshape(nodes.shape[0], 3, -1)
    return np.einsum("i,iak,ib->abk", masses, phi3, p)


def modal_loads(rec: dict[str, Any], J: np.ndarray, struts: np.ndarray, S: np.ndarray | None) -> np.ndarray:
    """(T, K) modal loads of the recorded polarities and field (and body rate with ``S``)."""
    act, B = rec["strut_activity"], rec["B_body_T"]
    T = B.shape[0]
    f = np.empty((T, J.shape[2]))
    Jf = J.reshape(-1, J.shape[2])
    for a in range(0, T, BLOCK):
        b = min(a + BLOCK, T)
        s = np.asarray(act[a:b])[:, struts].astype(float)
        sb = (s[:, :, None] * np.asarray(B[a:b])[:, None, :]).reshape(b - a, -1)
        f[a:b] = sb @ Jf
    if S is not None:
        w = np.asarray(rec["omega_est_body_rad_s"][...])
        A = np.einsum("t,ab->tab", (w * w).sum(axis=1), np.eye(3)) - np.einsum("ta,tb->tab", w, w)
        f += np.einsum("tab,abk->tk", A, S)
    return f


def rebuilt_torque(rec: dict[str, Any], lat, m_of_rod: np.ndarray, force_pair: str) -> np.ndarray:
    """(T, 3) moment Σ (r_j − r_i) × F_j of the rebuilt pairs on the undeformed struts [N m]."""
    rods = rod_array(lat)
    ri, rj = lat.nodes[rods.ends[:, 0]], lat.nodes[rods.ends[:, 1]]
    act, B = rec["strut_activity"], np.asarray(rec["B_body_T"][...])
    out = np.empty((B.shape[0], 3))
    for a in range(0, B.shape[0], BLOCK):
        b = min(a + BLOCK, B.shape[0])
        s = np.asarray(act[a:b])[:, rods.struts].astype(float)
        # pair forces are linear in B: moment per unit field axis, then combine
        Mc = np.stack([np.cross(rj - ri, pair_forces(force_pair, ri, rj, m_of_rod, e)) for e in np.eye(3)], axis=1)
        out[a:b] = np.einsum("tr,rcd,tc->td", s, Mc, B[a:b])
    return out


def bound_sd(phi_top: np.ndarray, top0: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(T,) SD of the top layer ``top0 + Φ_top q`` [m], block by block."""
    out = np.empty(q.shape[0])
    for a in range(0, q.shape[0], BLOCK):
        b = min(a + BLOCK, q.shape[0])
        u = (q[a:b] @ phi_top.T).reshape(b - a, -1, 3)
        out[a:b] = surface_sd(top0[None] + u)
    return out


def mode_table(idx: np.ndarray, omega: np.ndarray, strain: np.ndarray, total: np.ndarray) -> list[dict[str, float]]:
    """Rows (elastic mode number from 1, ω, period, strain and total energy, share of the total)."""
    tot = float(total.sum())
    return [
        {
            "mode": int(i) + 1,
            "omega_rad_s": float(omega[i]),
            "period_s": float(2 * np.pi / omega[i]),
            "strain_energy_J": float(strain[i]),
            "energy_J": float(total[i]),
            "energy_share": float(total[i] / tot) if tot > 0 else float("nan"),
        }
        for i in idx
    ]


def upper_bound(run_dir: Path, *, hold: str, centrifugal: bool, force_pair: str | None = None) -> dict[str, Any]:
    """The report of the module docstring for the run folder ``run_dir`` (``force_pair``: the
    variant to rebuild the loads with, default the run's)."""
    t0 = time.perf_counter()
    manifest = json.loads((run_dir / "manifest.json").read_text())
    cfg = parse_config(manifest["config"], source=str(run_dir / "manifest.json"))
    if cfg.concept != "truss_magnetorquer" or cfg.actuators.kind != "magnetorquer":
        raise ValueError(f"run_dir: not a truss magnetorquer run ({cfg.concept}, {cfg.actuators.kind})")
    tm = make_truss_model(cfg)
    lat = tm.lattice
    rec = lazy_arrays(run_dir)
    t = np.asarray(rec["t"][...])
    md = lattice_modes(lat.nodes, lat.struts, tm.k, tm.masses, use_cache=False)
    el = md.elastic
    phi, omega = md.phi[:, el], md.omega[el]
    m_of_rod = np.asarray(manifest["rod_dipole_Am2"], dtype=float)[rod_array(lat).family]
    run_pair = str(manifest.get("rod_force_pair", "corrected"))
    force_pair = force_pair or run_pair
    J, struts = rod_jacobian(lat, phi, m_of_rod, force_pair)
    S = centrifugal_basis(lat.nodes, tm.masses, phi) if centrifugal else None
    f = modal_loads(rec, J, struts, S)
    resp = undamped_modal_response(omega, t, f, hold=hold)
    top = lat.top_nodes
    rows = (3 * top[:, None] + np.arange(3)).ravel()
    sd = bound_sd(phi[rows], lat.nodes[top], resp.q)
    k = int(np.argmax(sd))
    strain, total = resp.strain_energy_J[k], resp.energy_J[k]
    sd_sim = np.asarray(rec["surface_sd_m"][...]) if "surface_sd_m" in rec else None
    T_rec = np.asarray(rec["torque_ac_body_Nm"][...])
    T_reb = rebuilt_torque(rec, lat, m_of_rod, run_pair)
    out: dict[str, Any] = {
        "run_dir": str(run_dir),
        "hold": hold,
        "centrifugal": centrifugal,
        "force_pair": force_pair,
        "n_records": int(t.size),
        "t_end_s": float(t[-1]),
        "n_elastic_modes": int(omega.size),
        "sd_bound_max_m": float(sd[k]),
        "t_sd_bound_max_s": float(t[k]),
        "sd_bound_period_s": float(dominant_period(t, sd)),
        "sd_bound_rms_m": float(np.sqrt(np.mean(sd**2))),
        "modal_energy_at_bound_max_J": float(total.sum()),
        "modal_strain_energy_at_bound_max_J": float(strain.sum()),
        "modes_top_energy_at_bound_max": mode_table(np.argsort(total)[::-1][:N_TOP_MODES], omega, strain, total),
        "modes_first5_at_bound_max": mode_table(np.arange(5), omega, strain, total),
        "torque_rebuilt_rel_err": float(np.linalg.norm(T_reb - T_rec) / max(np.linalg.norm(T_rec), 1e-300)),
    }
    if sd_sim is not None:
        i = int(np.argmax(sd_sim))
        out.update(
            sd_sim_max_m=float(sd_sim[i]),
            t_sd_sim_max_s=float(t[i]),
            sd_sim_period_s=float(dominant_period(t, sd_sim)),
            sd_sim_rms_m=float(np.sqrt(np.mean(sd_sim**2))),
            sd_correlation=float(np.corrcoef(sd, sd_sim)[0, 1]),
            ratio_bound_to_sim=float(sd[k] / sd_sim[i]) if sd_sim[i] > 0 else float("inf"),
        )
    out["wall_time_s"] = time.perf_counter() - t0
    return out


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        out = upper_bound(args.run_dir, hold=args.hold, centrifugal=args.centrifugal, force_pair=args.force_pair)
    except (OSError, KeyError, RecordStoreError, ConfigError, ValueError) as exc:
        print(f"error: run_dir {args.run_dir}: {exc}", file=sys.stderr)
        return 2
    text = json.dumps(out, indent=2)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
