r"""How to inject the co-rotated Caughey damping into MuJoCo (Robb et al. 2022b, Eq. 15).

Case: the stiffest case, N = 27 units, EI = 1e4 N m², D = 250 m,
σ_A = 0.1 kg/m² (uniform particle masses), Δt = 0.05 s RK4, 500 s, free space, geometry-A
perimeter loop with a constant current (default 40 A) in a uniform B = 27.7 μT along +x
(Eq. 16 node forces on the deformed positions), paper_max damping schedule, co-rotated.

Three integrations of the same equations (Eq. 12 with exact tendon springs):

(a) ``xfrc``: MuJoCo RK4 through the runner; Lorentz and damping loads computed once per step
    from ``qpos/qvel`` and held over the step in ``xfrc_applied`` (the project's single door);
(b) ``passive``: the same, but the damping enters through the ``mjcb_passive`` callback (RK4
    evaluates it at every stage); Lorentz still held per step;
(ref) the plain NumPy RK4 of :mod:`magsail_mj.reference.numpy_rk4` with the damping (float64
    γ by default) and the Lorentz forces evaluated at every stage.

Criteria (ours): best-fit rotation angle within 1e-3 rad of (ref) at every record time, and
max strain energy within 2 %. Reported: max |θ_x − θ_ref|, the largest angle of the relative
rotation R_x^T R_ref, max U and its relative difference, the wall and CPU cost per step.

Then (unless ``--skip-cost``) the damping cost per step at N = 12, 19, 27 against the bare
MuJoCo RK4 step (CPU time, best of 3 repeats), for float32 and float64 γ, and the float32 force
error. BLAS runs single-threaded (``OPENBLAS_NUM_THREADS=1`` unless set): on the shared 2-core
machine two BLAS threads were measured 2–5 times slower per mat-vec.

    python scripts/check_damping_injection.py --units 19
    python scripts/check_damping_injection.py --units 27 --duration-s 500 --out runs/checks/inj27.json
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import magsail_mj  # noqa: E402,F401  (GL backend before mujoco)
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from magsail_mj.lattice.modes import stability_products  # noqa: E402
from magsail_mj.estimation.attitude import rotation_angle  # noqa: E402
from magsail_mj.lattice.geometry import make_lattice  # noqa: E402
from magsail_mj.lattice.properties import strut_stiffness  # noqa: E402
from magsail_mj.io import write_json  # noqa: E402
from magsail_mj.lattice.modal_damping import ModalDampingLoad, passive_damping  # noqa: E402
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec  # noqa: E402
from magsail_mj.reference.numpy_rk4 import SpringMassLattice  # noqa: E402
from magsail_mj.sim import Simulation  # noqa: E402
from magsail_mj.lattice.modes import caughey_matrix  # noqa: E402

try:  # the current-loop modules (another part of the project); a local fallback otherwise
    from magsail_mj.geometry.current_loops import circuit as _circuit
    from magsail_mj.concepts.current_loops.lorentz import CircuitSegments, LorentzLoad, lorentz_node_forces

    HAVE_LORENTZ = True
except ImportError:  # pragma: no cover
    HAVE_LORENTZ = False

B_T = np.array([27.7e-6, 0.0, 0.0])
SIDE_M = 250.0
SIGMA = 0.1


def perimeter_segments(lat):
    """Geometry-A loop (top layer, counter-clockwise about +z) as (src, dst) node arrays."""
    n = lat.units
    N = n + 1
    top = N * N
    ring = (
        [(i, 0) for i in range(n)]
        + [(n, j) for j in range(n)]
        + [(i, n) for i in range(n, 0, -1)]
        + [(0, j) for j in range(n, 0, -1)]
    )
    idx = np.array([top + j * N + i for i, j in ring])
    return idx, np.roll(idx, -1)


class _LocalLorentz:
    """Fallback Eq.-16 load: f = ½ I (r_b − r_a) × B to both end nodes."""

    name = "lorentz"

    def __init__(self, src, dst, current_A, B, n_nodes):
        self.src, self.dst, self.I, self.B, self.n = src, dst, current_A, B, n_nodes

    def node_forces(self, pos):
        f = 0.5 * self.I * np.cross(pos[self.dst] - pos[self.src], self.B)
        F = np.zeros((self.n, 3))
        np.add.at(F, self.src, f)
        np.add.at(F, self.dst, f)
        return F

    def add(self, state, xfrc):
        xfrc[1 : self.n + 1, :3] += self.node_forces(state.pos[1 : self.n + 1])


def build(units: int, EI: float, dt: float, current_A: float):
    lat = make_lattice(units=units, side_m=SIDE_M)
    k, _ = strut_stiffness(lat, EI_Nm2=EI, calibration="formula")
    m = np.full(lat.n_nodes, SIGMA * SIDE_M**2 / lat.n_nodes)
    model = build_truss_spec(
        lat, masses=m, stiffness=k, damping=0.0, options=TrussModelOptions(timestep_s=dt, integrator="RK4")
    ).compile()
    if HAVE_LORENTZ:
        segs = CircuitSegments([_circuit(lat, "A")])
        lorentz = LorentzLoad(segs, n_nodes=lat.n_nodes, currents_A=[current_A], B_world=B_T)

        def lorentz_f(x):
            return lorentz_node_forces(x, segs, [current_A], B_T)
    else:
        src, dst = perimeter_segments(lat)
        lorentz = _LocalLorentz(src, dst, current_A, B_T, lat.n_nodes)
        lorentz_f = lorentz.node_forces
    return lat, k, m, model, lorentz, lorentz_f


class Metrics:
    """Best-fit rotation and strain energy of node positions."""

    def __init__(self, lat, k, load: ModalDampingLoad):
        self.lat, self.k, self.load = lat, k, load

    def __call__(self, x):
        R = self.load.rotation(x)
        r = x[self.lat.struts[:, 1]] - x[self.lat.struts[:, 0]]
        U = 0.5 * np.sum(self.k * (np.linalg.norm(r, axis=1) - self.lat.rest_length) ** 2)
        return R, U


def run_mujoco(model, lat, loads, metrics, duration, record_every, *, passive_load=None):
    sim = Simulation(
        model=model,
        duration_s=duration,
        loads=loads,
        record_every=record_every,
        probes={"x": lambda s, d: s.pos[1 : lat.n_nodes + 1]},
    )
    c0, w0 = time.process_time(), time.perf_counter()
    if passive_load is None:
        res = sim.run()
        calls = None
    else:
        with passive_damping(model, passive_load) as cb:
            res = sim.run()
        calls = cb.calls
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    if res.status != "completed":
        raise RuntimeError(f"MuJoCo run {res.status}: {res.message}")
    Rs, Us = zip(*(metrics(x) for x in res.records["x"]))
    return {
        "t": res.records["t"],
        "R": np.array(Rs),
        "U": np.array(Us),
        "cpu_s": cpu,
        "wall_s": wall,
        "steps": res.steps,
        "passive_calls": calls,
    }


def run_reference(lat, m, k, damping, lorentz_f, metrics, dt, duration, record_every):
    system = SpringMassLattice(masses=m, struts=lat.struts, k=k, l0=lat.rest_length, gamma=0.0)

    def external(t, x, v):
        return damping.forces(x, v) + lorentz_f(x)

    x, v = lat.nodes.copy(), np.zeros_like(lat.nodes)
    n_steps = int(round(duration / dt))
    ts, Rs, Us = [], [], []
    c0, w0 = time.process_time(), time.perf_counter()
    for step in range(n_steps + 1):
        if step % record_every == 0:
            R, U = metrics(x)
            ts.append(step * dt)
            Rs.append(R)
            Us.append(U)
        if step == n_steps:
            break
        x, v = system.rk4_step(step * dt, x, v, dt, external)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return {"t": np.array(ts), "R": np.array(Rs), "U": np.array(Us), "cpu_s": cpu, "wall_s": wall, "steps": n_steps}


def compare(run, ref):
    if run["t"].shape != ref["t"].shape or not np.allclose(run["t"], ref["t"]):
        raise RuntimeError("record times differ")
    th, th_ref = rotation_angle(run["R"]), rotation_angle(ref["R"])
    rel = rotation_angle(run["R"], relative_to=ref["R"])
    Umax, Umax_ref = float(run["U"].max()), float(ref["U"].max())
    return {
        "angle_err_max_rad": float(np.max(np.abs(th - th_ref))),
        "rel_rotation_max_rad": float(rel.max()),
        "U_max_J": Umax,
        "U_max_rel_err": abs(Umax - Umax_ref) / Umax_ref,
        "t_U_max_s": float(run["t"][np.argmax(run["U"])]),
        "angle_end_rad": float(th[-1]),
        "cpu_ms_per_step": 1e3 * run["cpu_s"] / run["steps"],
        "wall_ms_per_step": 1e3 * run["wall_s"] / run["steps"],
        "passes": bool(
            np.max(np.abs(th - th_ref)) <= 1e-3 and rel.max() <= 1e-3 and abs(Umax - Umax_ref) <= 0.02 * Umax_ref
        ),
    }


def injection_check(args) -> dict:
    lat, k, m, model, lorentz, lorentz_f = build(args.units, args.EI, args.dt, args.current_A)
    t0 = time.perf_counter()
    dmp = ModalDampingLoad.for_lattice(
        nodes=lat.nodes, struts=lat.struts, k=k, masses=m, schedule="paper_max", dtype=np.float32
    )
    t_build = time.perf_counter() - t0
    dmp64 = None
    if args.ref_dtype == "float64" or args.xfrc64:
        dmp64 = ModalDampingLoad(modes=dmp.modes, nodes=lat.nodes, gamma=_gamma64(dmp), dtype=np.float64)
    ref_load = dmp64 if args.ref_dtype == "float64" else dmp
    metrics = Metrics(lat, k, dmp)
    stab = stability_products(dmp.modes.omega, dmp.ratios, dt=args.dt)
    rec = max(1, int(round(args.record_s / args.dt)))
    print(
        f"N = {args.units}: {lat.n_nodes} nodes, {lat.n_struts} struts, {3 * lat.n_nodes} DOF; "
        f"modes + gamma {t_build:.1f} s; omega_max = {dmp.modes.omega[-1]:.4f} rad/s; "
        f"2 xi omega_max dt = {stab.damping_product:.3f}",
        flush=True,
    )
    out = {
        "units": args.units,
        "EI_Nm2": args.EI,
        "dt_s": args.dt,
        "duration_s": args.duration_s,
        "current_A": args.current_A,
        "B_T": B_T.tolist(),
        "lorentz_module": HAVE_LORENTZ,
        "ref_gamma_dtype": args.ref_dtype,
        "omega_max_rad_s": float(dmp.modes.omega[-1]),
        **stab.as_dict(),
        "runs": {},
    }
    runs = {}
    runs["ref"] = run_reference(lat, m, k, ref_load, lorentz_f, metrics, args.dt, args.duration_s, rec)
    print(f"  ref     done: {runs['ref']['wall_s']:.0f} s wall", flush=True)
    runs["xfrc"] = run_mujoco(model, lat, [lorentz, dmp], metrics, args.duration_s, rec)
    print(f"  xfrc    done: {runs['xfrc']['wall_s']:.0f} s wall", flush=True)
    runs["passive"] = run_mujoco(model, lat, [lorentz], metrics, args.duration_s, rec, passive_load=dmp)
    print(
        f"  passive done: {runs['passive']['wall_s']:.0f} s wall ({runs['passive']['passive_calls']} callback calls)",
        flush=True,
    )
    if args.xfrc64:
        runs["xfrc_f64"] = run_mujoco(model, lat, [lorentz, dmp64], metrics, args.duration_s, rec)
    ref = runs["ref"]
    out["ref"] = {
        "U_max_J": float(ref["U"].max()),
        "t_U_max_s": float(ref["t"][np.argmax(ref["U"])]),
        "angle_end_rad": float(rotation_angle(ref["R"][-1])),
        "cpu_ms_per_step": 1e3 * ref["cpu_s"] / ref["steps"],
        "wall_ms_per_step": 1e3 * ref["wall_s"] / ref["steps"],
    }
    for name, r in runs.items():
        if name != "ref":
            out["runs"][name] = compare(r, ref)
    if args.xfrc64:
        out["xfrc_f32_vs_f64_rel_rotation_max_rad"] = float(
            rotation_angle(runs["xfrc"]["R"], relative_to=runs["xfrc_f64"]["R"]).max()
        )
        out["xfrc_f32_vs_f64_U_max_rel"] = float(
            abs(runs["xfrc"]["U"].max() - runs["xfrc_f64"]["U"].max()) / runs["xfrc_f64"]["U"].max()
        )
    return out


def _gamma64(load: ModalDampingLoad) -> np.ndarray:
    return caughey_matrix(load.modes, load.ratios)


def _best_cpu(f, n, repeats=3) -> float:
    f()
    best = np.inf
    for _ in range(repeats):
        c0 = time.process_time()
        for _ in range(n):
            f()
        best = min(best, (time.process_time() - c0) / n)
    return 1e3 * best


def cost_table(args) -> list[dict]:
    rows = []
    for units in (12, 19, 27):
        lat, k, m, model, lorentz, lorentz_f = build(units, args.EI, args.dt, args.current_A)
        d32 = ModalDampingLoad.for_lattice(nodes=lat.nodes, struts=lat.struts, k=k, masses=m)
        d64 = ModalDampingLoad(modes=d32.modes, nodes=lat.nodes, gamma=_gamma64(d32), dtype=np.float64)
        rng = np.random.default_rng(0)
        pos = lat.nodes + rng.normal(size=lat.nodes.shape) * 0.05
        vel = rng.normal(size=pos.shape) * 1e-3
        F64 = d64.forces(pos, vel)
        err32 = float(np.abs(d32.forces(pos, vel) - F64).max() / np.abs(F64).max())
        data = mujoco.MjData(model)
        data.qvel[:] = vel.ravel()
        n = max(20, int(4000 / (3 * lat.n_nodes) * 10))
        t_mj = _best_cpu(lambda: mujoco.mj_step(model, data), n)
        t32 = _best_cpu(lambda: d32.forces(pos, vel), n)
        t64 = _best_cpu(lambda: d64.forces(pos, vel), n)
        t_fit = _best_cpu(lambda: d32.rotation(pos), n)
        with passive_damping(model, d32):
            t_pass = _best_cpu(lambda: mujoco.mj_step(model, data), n)
        row = {
            "units": units,
            "dof": 3 * lat.n_nodes,
            "gamma_MB_f32": d32._dense.nbytes / 2**20,
            "mj_step_ms": t_mj,
            "damping_f32_ms": t32,
            "damping_f64_ms": t64,
            "best_fit_ms": t_fit,
            "mj_step_passive_f32_ms": t_pass,
            "xfrc_step_ms": t_mj + t32,
            "f32_force_rel_err": err32,
        }
        rows.append(row)
        print(
            "  cost " + json.dumps({k_: (float(f"{v:.4g}") if isinstance(v, float) else v) for k_, v in row.items()}),
            flush=True,
        )
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--units", type=int, default=27)
    p.add_argument("--EI", type=float, default=1e4, help="bending stiffness [N m^2]")
    p.add_argument("--dt", type=float, default=0.05, help="time step [s]")
    p.add_argument("--duration-s", type=float, default=500.0)
    p.add_argument("--current-A", type=float, default=40.0)
    p.add_argument("--record-s", type=float, default=0.5, help="record interval [s]")
    p.add_argument("--ref-dtype", choices=("float64", "float32"), default="float64")
    p.add_argument("--xfrc64", action="store_true", help="also run (a) with a float64 gamma")
    p.add_argument("--skip-check", action="store_true")
    p.add_argument("--skip-cost", action="store_true")
    p.add_argument("--out", default=None, help="write the results as JSON here")
    args = p.parse_args(argv)
    result = {"blas_threads": os.environ.get("OPENBLAS_NUM_THREADS")}
    if not args.skip_check:
        result["check"] = injection_check(args)
    if not args.skip_cost:
        result["cost"] = cost_table(args)
    print(json.dumps(result, indent=1))
    if not args.skip_check:
        c = result["check"]
        for name, r in c["runs"].items():
            print(
                f"VERDICT {name:8s} N={c['units']} {c['duration_s']:.0f} s: "
                f"{'PASS' if r['passes'] else 'FAIL'}  angle err {r['angle_err_max_rad']:.2e} rad "
                f"(rel. rotation {r['rel_rotation_max_rad']:.2e}), max U {r['U_max_J']:.4g} J "
                f"(rel. err {100 * r['U_max_rel_err']:.3f} %), {r['wall_ms_per_step']:.2f} ms/step wall"
            )
        ok = c["runs"]["xfrc"]["passes"]
        print(
            "VERDICT: default xfrc injection "
            + ("PASSES" if ok else "FAILS")
            + " the injection check"
            + ("" if ok else "; use the passive callback")
        )
    if args.out:
        write_json(args.out, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
