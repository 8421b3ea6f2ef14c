"""MSAC videos: V1 slow-motion cycles, V2 time-lapse of the 600 s run.

    # after: magsail run magsail_mj/concepts/msac/configs/slow_1hz.toml --out runs/msac/slow_1hz
    python scripts/msac_videos.py v1 runs/msac/slow_1hz
    python scripts/msac_videos.py v2 runs/msac/paper_1khz          # after the 600 s run

Both are rendered with :func:`magsail_mj.render.render_run` from a *render folder* written next
to the run (``<run>/render_v1``, ``<run>/render_v2``): ``model.xml``, ``manifest.json`` and a
a record store ``timeseries.zarr`` holding the frames to show (written with
:func:`magsail_mj.records.write_group`; the run's own store is read, never changed).

* **V1**: the first ``--cycles`` (default 3) cycles of a low-frequency run, every record a frame,
  camera looking down world Z. The slide coordinates are multiplied by ``--exaggerate``
  (default: the config's ``render.extension_exaggeration``, 10) in the render folder only, and the
  title says so; the bend angle is not exaggerated. Overlay: accumulated bus yaw and the phase
  number (1 = I→II bend extended, 2 = II→III contract, 3 = III→IV bend back contracted,
  4 = IV→I extend). A fixed world marker bar lies beyond the +X wing tip.
* Both videos look straight down world Z, where the 3 cm thick panels would be hairlines, so the
  render folder's model draws them ``PANEL_DRAWN_M`` = 0.25 m thick (their geoms are massless:
  the picture changes, the recorded motion does not).
* **V2**: stroboscopic frames of the long run (the run's records are taken at cycle starts), one
  frame every ``N`` cycles so that the bus turns ≤ ``--max-deg-per-frame`` (default 20°) between
  frames (avoids wagon-wheel aliasing), with the clock and the accumulated yaw.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
from pathlib import Path

import mujoco
import numpy as np

from magsail_mj.export import read_timeseries
from magsail_mj.io import write_json
from magsail_mj.records import STORE_NAME, write_group
from magsail_mj.render import render_run

#: drawn thickness of the wing panels in the videos [m] (the model's is 0.03 m; see _render_model)
PANEL_DRAWN_M = 0.25


def _load(run: Path) -> tuple[dict, dict[str, np.ndarray], dict]:
    man = json.loads((run / "manifest.json").read_text())
    ts = read_timeseries(run)
    summ = json.loads((run / "summary.json").read_text())
    return man, ts, summ


def _write_frames(rdir: Path, **arrays: np.ndarray) -> Path:
    """The render folder's record store ``rdir/timeseries.zarr`` holding exactly ``arrays``
    (time ``t`` [s] first axis of each; an earlier store there is replaced whole)."""
    store = rdir / STORE_NAME
    if store.exists():
        shutil.rmtree(store)
    write_group(store, arrays, n_time=len(arrays["t"]))
    return store


def _slide_columns(model_xml: Path) -> np.ndarray:
    m = mujoco.MjModel.from_xml_path(str(model_xml))
    return np.array([m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)] for j in ("w1_ext", "w2_ext")])


def _render_model(run: Path, rdir: Path, *, panel_thickness_m: float) -> None:
    """Copy the run's model into ``rdir`` with the wing panels *drawn* ``panel_thickness_m``
    thick: seen from straight above, a 3 cm panel is a hairline. The panel geoms carry no mass
    (the wings' inertials are explicit), so only the picture changes."""
    spec = mujoco.MjSpec.from_file(str(run / "model.xml"))
    for name in ("w1_panel", "w2_panel"):
        g = spec.geom(name)
        g.size = [g.size[0], max(g.size[1], panel_thickness_m / 2), g.size[2]]
    (rdir / "model.xml").write_text(spec.to_xml())


def make_v1(run: Path, out: Path, *, cycles: int, exaggerate: float | None) -> Path:
    """Render V1 (see module docs) and return the video path."""
    man, ts, summ = _load(run)
    f = man["config"]["cycle"]["frequency_Hz"]
    k = exaggerate if exaggerate is not None else man["config"]["render"]["extension_exaggeration"]
    sel = ts["t"] <= cycles / f + 1e-12
    qpos = ts["qpos"][sel].copy()
    cols = _slide_columns(run / "model.xml")
    qpos[:, cols] *= k
    rdir = run / "render_v1"
    rdir.mkdir(exist_ok=True)
    _render_model(run, rdir, panel_thickness_m=PANEL_DRAWN_M)
    yaw = ts["yaw_unwrapped_rad"][sel]
    _write_frames(rdir, t=ts["t"][sel], qpos=qpos, bus_yaw_rad=yaw - yaw[0], phase=ts["phase"][sel].astype(float))
    render = dict(man["render"])
    render["title"] = f"MSAC at {f:g} Hz: slide drawn ×{k:g}, bend true"
    render["overlay"] = ["bus_yaw_rad", "phase"]
    render.pop("extension_exaggeration", None)
    write_json(rdir / "manifest.json", {"render": render, "source_run": str(run)})
    cam = render["camera"]
    return render_run(
        rdir,
        out,
        fps=float(render.get("fps", 30)),
        max_frames=int(sel.sum()),
        camera=cam,
        labels=["phase 1 bend (extended) · 2 contract · 3 bend back (contracted) · 4 extend"],
    )


def make_v2(run: Path, out: Path, *, max_deg_per_frame: float, max_frames: int, fps: float) -> Path:
    """Render V2 (see module docs) and return the video path."""
    man, ts, summ = _load(run)
    t, qpos, yaw = ts["t"], ts["qpos"], ts["yaw_unwrapped_rad"]
    f = man["config"]["cycle"]["frequency_Hz"]
    T = 1.0 / f
    on_cycle = np.abs(t / T - np.round(t / T)) < 1e-6
    t, qpos, yaw = t[on_cycle], qpos[on_cycle], yaw[on_cycle]
    per_record = np.abs(np.diff(yaw)).mean() if yaw.size > 1 else 0.0
    step = max(1, int(math.floor(math.radians(max_deg_per_frame) / per_record))) if per_record > 0 else 1
    idx = np.arange(0, t.size, step)
    if idx.size > max_frames:
        idx = idx[np.round(np.linspace(0, idx.size - 1, max_frames)).astype(int)]
    rdir = run / "render_v2"
    rdir.mkdir(exist_ok=True)
    _render_model(run, rdir, panel_thickness_m=PANEL_DRAWN_M)
    _write_frames(rdir, t=t[idx], qpos=qpos[idx], bus_yaw_rad=yaw[idx] - yaw[0])
    cyc = int(round((t[idx[1]] - t[idx[0]]) / T)) if idx.size > 1 else 0
    render = dict(man["render"])
    render["title"] = f"MSAC {f:g} Hz time-lapse: stroboscopic frame every {cyc} cycles"
    render["overlay"] = ["bus_yaw_rad"]
    render.pop("extension_exaggeration", None)
    write_json(rdir / "manifest.json", {"render": render, "source_run": str(run)})
    return render_run(
        rdir,
        out,
        fps=fps,
        max_frames=idx.size,
        camera=render["camera"],
        labels=[f"secular rate (slope of the yaw) {summ['secular_rate_rad_s']:.4g} rad/s"],
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("which", choices=["v1", "v2"])
    ap.add_argument("run", type=Path, help="run folder")
    ap.add_argument("-o", "--output", type=Path, help="MP4 path (default: <run>/<which>.mp4)")
    ap.add_argument("--cycles", type=int, default=3, help="V1: cycles shown")
    ap.add_argument("--exaggerate", type=float, default=None, help="V1: visual slide factor")
    ap.add_argument("--max-deg-per-frame", type=float, default=20.0, help="V2: bus turn per frame")
    ap.add_argument("--max-frames", type=int, default=3000, help="V2: most frames")
    ap.add_argument("--fps", type=float, default=60.0, help="V2: frames per second")
    a = ap.parse_args(argv)
    out = a.output or a.run / f"{a.which}.mp4"
    if a.which == "v1":
        path = make_v1(a.run, out, cycles=a.cycles, exaggerate=a.exaggerate)
    else:
        path = make_v2(a.run, out, max_deg_per_frame=a.max_deg_per_frame, max_frames=a.max_frames, fps=a.fps)
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
