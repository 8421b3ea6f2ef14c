"""The surface figures of a plate run of the ``structure`` concept, read as the truss concept reads
them: the top layer's surface standard deviation and its edge angle (Robb et al. 2022a).

    .venv/bin/python scripts/plate_readings.py RUN_DIR [RUN_DIR ...] [--top-set top]

For each run folder (``magsail run`` of a structure config, e.g.
``magsail_mj/concepts/structure/configs/octet_detumble.toml``) prints one JSON object per line:

* ``surface_sd_max_m``: the largest σ_SD = √(Σ h_i² / n) over the records, ``h_i`` the heights of
  the top-layer nodes above their total-least-squares plane
  (:func:`magsail_mj.analysis.flatness.surface_sd`, the truss concept's key of the same name), and
  its time ``t_surface_sd_max_s``;
* ``edge_angle_max_deg``: at that record, the largest local surface angle within one node spacing
  of the top layer's boundary, from the Clough–Tocher fit of the heights on a 0.25 m grid
  (:func:`magsail_mj.concepts.truss_magnetorquer.surface_angle.local_surface_angle`, the truss
  concept's edge angle), with the plane frame oriented by the recorded best-fit rotation;
* ``edge_angle_triangles_max_deg``: the same angle without a fit, for a top layer that is not a
  square grid (the octet's top nodes form a checkerboard whose boundary triangles are slivers,
  where the cubic fit overshoots): each triangle of the Delaunay triangulation of the nodes' plane
  coordinates ``(u, v)`` carries the plane through its three nodes, normal ``N = (p₁ − p₀) × (p₂ −
  p₀)`` in the average-plane frame and angle ``α = atan(√(N_u² + N_v²) / |N_w|)`` (exact for a
  linear height field); the largest ``α`` over the triangles with a node on the hull and every
  corner angle at least :data:`MIN_CORNER_DEG` (slivers, whose heights differences are divided by
  a near-zero width, are left out), and the largest over all such triangles
  (``triangle_angle_max_deg``);
* the summary's ``shape_rms_max_m`` (the structure concept's deviation from the best-fit reference
  shape: every node, in-plane included) beside them, and the wall time per step
  (``wall_time_s / steps`` of the manifest).

Node positions come from the recorded ``qpos`` through the run's own model (the config in the
run's manifest, rebuilt): ``x_i = pos_b + R_b offset_i`` of each node's body (world frame).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import magsail_mj  # noqa: F401  first: chooses the GL backend before mujoco is imported
import mujoco
import numpy as np
from scipy.spatial import Delaunay

from magsail_mj.analysis.flatness import surface_sd
from magsail_mj.concepts.structure.model import make_structure_model
from magsail_mj.concepts.truss_magnetorquer.surface_angle import local_surface_angle, plane_frame
from magsail_mj.config import parse_config
from magsail_mj.records import open_records

#: the smallest corner angle of a triangle counted by the fit-free edge angle [deg]
MIN_CORNER_DEG = 20.0


def triangle_angles(top_m: np.ndarray, R_body: np.ndarray) -> tuple[float, float]:
    """``(largest angle over the well-shaped boundary triangles, over all well-shaped triangles)``
    [deg] of the top layer ``top_m`` (n, 3) at one time (module docstring)."""
    c, n, eu, ev = plane_frame(top_m, R_body)
    X = top_m - c
    uv = np.stack([X @ eu, X @ ev], axis=-1)
    tri = Delaunay(uv)
    P = np.concatenate([uv, (X @ n)[:, None]], axis=1)[tri.simplices]  # (m, 3 corners, 3)
    N = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    alpha = np.degrees(np.arctan(np.hypot(N[:, 0], N[:, 1]) / np.abs(N[:, 2])))
    corners = uv[tri.simplices]
    sides = np.stack([np.linalg.norm(corners[:, (k + 1) % 3] - corners[:, (k + 2) % 3], axis=1) for k in range(3)], 1)
    a, b, d = sides.T
    cos = np.stack([(b * b + d * d - a * a) / (2 * b * d), (a * a + d * d - b * b) / (2 * a * d)], axis=1)
    first_two = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    smallest = np.minimum(first_two.min(axis=1), 180.0 - first_two.sum(axis=1))
    on_hull = np.zeros(len(uv), dtype=bool)
    on_hull[np.unique(tri.convex_hull)] = True
    good = smallest >= MIN_CORNER_DEG
    boundary = good & on_hull[tri.simplices].any(axis=1)
    return float(alpha[boundary].max()), float(alpha[good].max())


def top_positions(run_dir: Path, *, top_set: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """``(t, top-layer positions (T, n, 3), best-fit rotations (T, 3, 3), manifest)`` of a run."""
    manifest = json.loads((run_dir / "manifest.json").read_text(encoding="utf-8"))
    cfg = parse_config(manifest["config"], source=str(run_dir / "manifest.json"))
    sm = make_structure_model(cfg)
    sets = sm.structure.node_sets
    if top_set not in sets:
        raise KeyError(f"--top-set: {top_set!r} is not a node set of the structure (sets: {sorted(sets)})")
    top = np.asarray(sets[top_set], dtype=np.int64)
    frames = sm.nodes.subset(top)
    records = open_records(run_dir)
    t = np.asarray(records["t"], dtype=float)
    qpos = np.asarray(records["qpos"], dtype=float)
    R = np.asarray(records["R_fit"], dtype=float)
    data = mujoco.MjData(sm.model)
    x = np.empty((len(t), top.size, 3))
    for k in range(len(t)):
        data.qpos[:] = qpos[k]
        mujoco.mj_kinematics(sm.model, data)
        x[k] = frames.positions(data.xpos.copy(), data.xquat)
    return t, x, R, manifest


def readings(run_dir: Path, *, top_set: str) -> dict:
    """The figures of the module docstring for one run folder."""
    t, x, R, manifest = top_positions(run_dir, top_set=top_set)
    sd = np.asarray(surface_sd(x))
    k = int(np.argmax(sd))
    angle = local_surface_angle(x[k], R[k])
    edge_tri_deg, tri_deg = triangle_angles(x[k], R[k])
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    steps = int(manifest.get("steps") or 0)
    return {
        "run": str(run_dir),
        "status": summary.get("status"),
        "n_top_nodes": int(x.shape[1]),
        "surface_sd_max_m": float(sd[k]),
        "t_surface_sd_max_s": float(t[k]),
        "surface_sd_final_m": float(sd[-1]),
        "edge_angle_max_deg": math.degrees(float(angle.edge_max)),
        "surface_angle_max_deg": math.degrees(float(angle.max)),
        "surface_angle_median_deg": math.degrees(float(angle.median)),
        "edge_angle_triangles_max_deg": edge_tri_deg,
        "triangle_angle_max_deg": tri_deg,
        "shape_rms_max_m": summary.get("shape_rms_max_m"),
        "shape_max_max_m": summary.get("shape_max_max_m"),
        "member_strain_max": summary.get("member_strain_max"),
        "t_rate_below_threshold_stay_s": summary.get("t_rate_below_threshold_stay_s"),
        "wall_time_per_step_s": float(manifest["wall_time_s"]) / steps if steps else float("nan"),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dirs", nargs="+", type=Path, help="run folders of structure-concept plate runs")
    ap.add_argument("--top-set", default="top", help="the node set of the top layer (default: top)")
    args = ap.parse_args(argv)
    for run_dir in args.run_dirs:
        if not (run_dir / "manifest.json").is_file():
            print(f"error: {run_dir}: not a finished run folder (no manifest.json)", file=sys.stderr)
            return 2
        print(json.dumps(readings(run_dir, top_set=args.top_set)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
