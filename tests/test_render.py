"""Rendering: GL backend choice and fallback, run-folder rendering, side-by-side, MP4 output.

Synthetic run folders are built here: a small truss lattice (``make_lattice`` +
``build_truss_spec``, MJCF from ``spec.to_xml()``) whose recorded ``qpos`` is a rigid rotation of
the plate (plus an optional bending shape), with strut activity that is 0, then +1, then −1 on
the top-layer x-edges; and a rigid satellite (one free body). Videos are read back with
``imageio-ffmpeg`` and checked for frame count, size, content, strut colours and codec.

The tests that render are skipped, with the reason, only when no OpenGL backend can create a
renderer at all (see ``magsail_mj.render.backend``).
"""

from __future__ import annotations

# The GL backend must be chosen before mujoco is imported (MUJOCO_GL is read at import time).
# Other test modules may have imported mujoco already; the first renderer then switches.
import warnings

from magsail_mj.render.backend import ensure_gl_backend

with warnings.catch_warnings():
    warnings.simplefilter("ignore", RuntimeWarning)
    ensure_gl_backend()

import dataclasses
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.spatial.transform import Rotation

from magsail_mj.config import load_config
from tests.conftest import load_file_module
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.mjcf import build_truss_spec
from magsail_mj.plotting import CHECK_ENV
from magsail_mj.render import backend, compose
from magsail_mj.render.compose import (
    RenderError,
    RunScene,
    frame_plan,
    load_run,
    render_frames,
    render_run,
)
from magsail_mj.render.ending import end_reason
from magsail_mj.render.overlay import format_time, free_rectangles, overlay_boxes
from magsail_mj.render.video import Mp4Writer, read_mp4, video_codec
from magsail_mj.resources import MemoryLimitError, memory_limit
from magsail_mj.run import run_scenario

W, H = 320, 180  # small frames keep software rendering fast
T_FRAMES = 9  # records: activity 0 (0-2), +1 (3-5), -1 (6-8)
REPO = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- helpers


@pytest.fixture(scope="session")
def gl() -> str:
    """The working GL backend; skips the rendering tests if there is none."""
    import mujoco

    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1'/></worldbody></mujoco>")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            r = backend.make_renderer(m, width=16, height=16)
    except backend.GLBackendError as exc:
        pytest.skip(f"no OpenGL backend can create a MuJoCo renderer: {exc}")
    r.close()
    return backend.active_backend()


def write_truss_run(
    folder: Path,
    *,
    units: int = 3,
    side_m: float = 10.0,
    T: int = T_FRAMES,
    duration_s: float = 80.0,
    bend_m: float = 0.0,
    activity: bool = True,
    title: str = "truss test",
    render: dict | None = None,
) -> dict:
    """A run folder whose plate turns rigidly by 60° about x and 30° about z over the run."""
    lat = make_lattice(units=units, side_m=side_m)
    spec = build_truss_spec(lat, masses=np.full(lat.n_nodes, 0.1), stiffness=np.full(lat.n_struts, 1.0), damping=0.01)
    model = spec.compile()
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "model.xml").write_text(spec.to_xml())
    t = np.linspace(0.0, duration_s, T)
    p0 = lat.nodes
    r2 = (p0[:, 0] ** 2 + p0[:, 1] ** 2) / (side_m / 2) ** 2
    qpos = np.empty((T, model.nq))
    for k, tk in enumerate(t):
        rot = Rotation.from_euler("xz", [60.0 * tk / duration_s, 30.0 * tk / duration_s], degrees=True).as_matrix()
        p = p0.copy()
        p[:, 2] += bend_m * r2
        qpos[k] = (p @ rot.T - p0).ravel()
    arrays = {
        "t": t,
        "qpos": qpos,
        "surface_sd_m": np.linspace(0.0, 0.01, T),
        "torque_cmd_Nm": np.linspace(-1e-3, 1e-3, T),
    }
    x_top = lat.struts_of_kind("x_edge", layer=1)
    if activity:
        act = np.zeros((T, lat.n_struts), np.int8)
        third = T // 3
        act[third : 2 * third, x_top] = 1
        act[2 * third :, x_top] = -1
        arrays["strut_activity"] = act
    np.savez(folder / "timeseries.npz", **arrays)
    manifest = {
        "config": {"units": units},
        "config_hash": "test",
        "scenario": "render_test",
        "files": {},  # a hand-made folder: no file to check (real runs list every file's digest)
        "render": {
            "title": title,
            "top_nodes": lat.top_nodes.tolist(),
            "overlay": ["surface_sd_m", "torque_cmd_Nm"],
            **(render or {}),
        },
    }
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return {"lattice": lat, "t": t, "qpos": qpos}


def write_rigid_run(folder: Path, *, T: int = 6) -> None:
    """A satellite (one free body: bus and two panels) turning about z while drifting along x."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "model.xml").write_text(
        textwrap.dedent("""\
        <mujoco model="sat">
          <option gravity="0 0 0"/>
          <worldbody>
            <light pos="0 0 5" dir="0 0 -1" directional="true"/>
            <body name="bus">
              <freejoint/>
              <geom type="box" size="0.3 0.2 0.1" rgba="0.8 0.7 0.2 1"/>
              <geom type="box" pos="0.8 0 0" size="0.5 0.3 0.005" rgba="0.2 0.3 0.8 1"/>
              <geom type="box" pos="-0.8 0 0" size="0.5 0.3 0.005" rgba="0.2 0.3 0.8 1"/>
            </body>
          </worldbody>
        </mujoco>""")
    )
    t = np.linspace(0.0, 10.0, T)
    qpos = np.zeros((T, 7))
    qpos[:, 0] = 0.1 * t
    qpos[:, 3:] = Rotation.from_euler("z", (9.0 * t)[:, None], degrees=True).as_quat(scalar_first=True)
    np.savez(folder / "timeseries.npz", t=t, qpos=qpos)
    (folder / "manifest.json").write_text(
        json.dumps(
            {"config": {}, "config_hash": "x", "scenario": "rigid", "render": {"title": "rigid sat"}, "files": {}}
        )
    )


def colour_counts(frame: np.ndarray) -> tuple[int, int]:
    """Pixels that are clearly red and clearly blue (the active strut colours)."""
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    red = (r > 140) & (r - g > 70) & (r - b > 70)
    blue = (b > 140) & (b - r > 70) & (b - g > 40)
    return int(red.sum()), int(blue.sum())


def run_python(code: str, **env: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter (MUJOCO_GL is fixed per process)."""
    full_env = {
        k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM", "MUJOCO_EGL_DEVICE_ID")
    }
    full_env.update(env)
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=full_env,
        cwd=REPO,
        timeout=120,
        check=False,
    )


PROBE = textwrap.dedent("""
    import warnings
    warnings.simplefilter("always")
    {prelude}
    from magsail_mj.render import backend
    backend.ensure_gl_backend()
    import mujoco
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><light pos="0 0 3"/>'
        '<geom type="sphere" size=".3" rgba="1 0 0 1"/></worldbody></mujoco>')
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    with backend.make_renderer(m, width=64, height=48) as r:
        r.update_scene(d)
        img = r.render()
    print("ACTIVE", backend.active_backend(), int((img[..., 0] > 150).sum()))
""")


def probe(prelude: str = "", **env: str) -> tuple[str | None, int, str]:
    proc = run_python(PROBE.format(prelude=textwrap.dedent(prelude).strip()), **env)
    for line in proc.stdout.splitlines():
        if line.startswith("ACTIVE"):
            _, name, red = line.split()
            return name, int(red), proc.stderr
    return None, 0, proc.stdout + proc.stderr


# --------------------------------------------------------------------------- backend


def test_ensure_gl_backend_prefers_osmesa(monkeypatch):
    for present, expected in ((True, "osmesa"), (False, "egl")):
        monkeypatch.delenv("MUJOCO_GL", raising=False)
        monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
        monkeypatch.setattr(backend, "osmesa_available", lambda present=present: present)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # "mujoco already imported"
            assert backend.ensure_gl_backend() == expected
        assert os.environ["MUJOCO_GL"] == expected
        assert os.environ["PYOPENGL_PLATFORM"] == expected
    # An explicit choice is respected.
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
    assert backend.ensure_gl_backend() == "egl"
    assert os.environ["PYOPENGL_PLATFORM"] == "egl"


def test_no_backend_raises_with_install_hint(monkeypatch):
    import mujoco

    def fail(*args, **kwargs):
        raise RuntimeError("simulated: cannot create a GL context")

    monkeypatch.setattr(backend, "_ACTIVE", None)
    monkeypatch.setattr(backend, "_try_renderer", fail)
    m = mujoco.MjModel.from_xml_string("<mujoco/>")
    with pytest.raises(backend.GLBackendError) as info:
        backend.make_renderer(m, width=16, height=16)
    msg = str(info.value)
    assert "apt-get install -y libosmesa6" in msg
    assert "MUJOCO_GL=osmesa" in msg and "MUJOCO_GL=egl" in msg
    with pytest.raises(ValueError, match="width"):
        backend.make_renderer(m, width=0, height=16)


@pytest.mark.parametrize("name", backend.HEADLESS_BACKENDS)
def test_each_backend_renders(name):
    if name == "osmesa" and not backend.osmesa_available():
        pytest.skip("libOSMesa is not installed (apt-get install -y libosmesa6)")
    active, red, err = probe(MUJOCO_GL=name)
    if active != name:
        pytest.skip(f"MUJOCO_GL={name} cannot render here (got {active}): {err[-500:]}")
    assert red > 100, "the red sphere is missing from the image"


def test_fallback_egl_to_osmesa():
    """A broken EGL (invalid device id) falls back to OSMesa, with a warning."""
    if not backend.osmesa_available():
        pytest.skip("libOSMesa is not installed")
    active, red, err = probe(MUJOCO_GL="egl", MUJOCO_EGL_DEVICE_ID="99")
    assert active == "osmesa", err
    assert "fell back to MUJOCO_GL='osmesa'" in err
    assert red > 100


def test_fallback_osmesa_to_egl():
    """Without OSMesa (simulated), rendering falls back to EGL, with a warning."""
    prelude = """
    import magsail_mj.render.backend as b
    _orig = b._switch_backend
    def _no_osmesa(name):
        if name == "osmesa":
            raise ImportError("simulated: libOSMesa missing")
        _orig(name)
    b._switch_backend = _no_osmesa
    """
    # PYOPENGL_PLATFORM=egl makes MuJoCo's own import of its OSMesa backend fail.
    active, red, err = probe(prelude, MUJOCO_GL="osmesa", PYOPENGL_PLATFORM="egl")
    if active is None and "GLBackendError" in err:
        pytest.skip("EGL cannot render on this machine either")
    assert active == "egl", err
    assert "fell back to MUJOCO_GL='egl'" in err
    assert red > 100


def test_mujoco_imported_first_still_renders():
    """If mujoco was imported before the backend was chosen, the first renderer switches."""
    active, red, err = probe(prelude="import mujoco")
    assert active in backend.HEADLESS_BACKENDS, err
    assert red > 100


def test_package_import_selects_backend():
    """``import magsail_mj`` must choose MUJOCO_GL before anything imports mujoco."""
    import magsail_mj

    init = Path(magsail_mj.__path__[0]) / "__init__.py"
    if not init.is_file() or "ensure_gl_backend" not in init.read_text():
        pytest.skip("magsail_mj/__init__.py does not call ensure_gl_backend() yet")
    proc = run_python("""
        import os, magsail_mj, mujoco
        from mujoco.rendering.classic import gl_context
        print("GL", os.environ.get("MUJOCO_GL"), gl_context.GLContext.__module__)
    """)
    line = next(x for x in proc.stdout.splitlines() if x.startswith("GL"))
    _, chosen, module = line.split()
    assert chosen in backend.HEADLESS_BACKENDS
    assert module == f"mujoco.{chosen}"


# --------------------------------------------------------------------------- video I/O


def test_mp4_writer_is_atomic(tmp_path):
    out = tmp_path / "v.mp4"
    out.write_bytes(b"old")
    with pytest.raises(RuntimeError, match="boom"), Mp4Writer(out, width=32, height=16, fps=10) as w:
        w.add(np.zeros((16, 32, 3), np.uint8))
        raise RuntimeError("boom")
    assert out.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.mp4"]
    with Mp4Writer(out, width=32, height=16, fps=10) as w:
        for k in range(3):
            w.add(np.full((16, 32, 3), 80 * k, np.uint8))
    assert read_mp4(out).shape == (3, 16, 32, 3)
    assert video_codec(out) == "h264 yuv420p"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.mp4"]
    with pytest.raises(ValueError, match="width"):
        Mp4Writer(out, width=33, height=16)
    with pytest.raises(ValueError, match="path"):
        Mp4Writer(tmp_path / "v.avi", width=32, height=16)


# --------------------------------------------------------------------------- run rendering


def test_frame_plan_nearest_and_hold():
    ta = np.linspace(0.0, 100.0, 101)
    tb = np.linspace(0.0, 40.0, 9)  # shorter run, coarser records
    ft, (ia, ib), (ea, eb) = frame_plan([tb, ta], max_frames=11)
    assert np.allclose(ft, np.linspace(0.0, 100.0, 11))  # the longer run sets the times
    assert np.array_equal(ib, np.arange(0, 101, 10))
    assert np.allclose(tb[ia], [0, 10, 20, 30, 40, 40, 40, 40, 40, 40, 40])
    assert ea.tolist() == [False] * 5 + [True] * 6 and not eb.any()
    with pytest.raises(ValueError, match="max_frames"):
        frame_plan([ta], max_frames=0)


def test_render_truss_run(tmp_path, gl):
    write_truss_run(tmp_path / "run_a")
    out = render_run(tmp_path / "run_a", tmp_path / "videos" / "a.mp4", width=W, height=H, fps=10)
    assert out == tmp_path / "videos" / "a.mp4"
    assert sorted(p.name for p in out.parent.iterdir()) == ["a.mp4"]  # no temp file left
    assert video_codec(out) == "h264 yuv420p"
    v = read_mp4(out)
    assert v.shape == (T_FRAMES, H, W, 3)
    assert all(frame.std() > 10 for frame in v), "blank frame"
    assert not np.array_equal(v[0], v[-1]), "the plate does not move"
    red = [colour_counts(f)[0] for f in v]
    blue = [colour_counts(f)[1] for f in v]
    # Activity 0 in records 0-2, +1 in 3-5, -1 in 6-8 (the legend's swatches are in every frame).
    assert min(red[3:6]) > max(red[:3]) + 30, red
    assert min(blue[6:9]) > max(blue[:3]) + 30, blue
    assert max(red[6:9]) < min(red[3:6]), red

    v4 = read_mp4(render_run(tmp_path / "run_a", tmp_path / "b.mp4", width=W, height=H, max_frames=4))
    assert v4.shape == (4, H, W, 3)


def test_render_side_by_side(tmp_path, gl):
    write_truss_run(tmp_path / "design_a")
    write_truss_run(tmp_path / "design_b", T=5, duration_s=40.0, activity=False, bend_m=0.3, title="bent")
    out = render_run(tmp_path / "design_a", tmp_path / "ab.mp4", compare=tmp_path / "design_b", width=W, height=H)
    v = read_mp4(out)
    assert v.shape == (T_FRAMES, H, 2 * W, 3)
    assert video_codec(out) == "h264 yuv420p"
    left, right = v[:, :, :W], v[:, :, W:]
    assert all(f.std() > 10 for f in left) and all(f.std() > 10 for f in right)
    # Activity exists only in the left run.
    assert colour_counts(left[4])[0] > colour_counts(right[4])[0] + 30
    # The shorter right run holds its last record once it has ended.
    assert np.abs(right[-1].astype(int) - right[-2]).mean() < 1.0
    with pytest.raises(ValueError, match="labels"):
        render_run(
            tmp_path / "design_a",
            tmp_path / "x.mp4",
            compare=tmp_path / "design_b",
            labels=["only one"],
            width=W,
            height=H,
        )


def test_render_rigid_body_run(tmp_path, gl):
    write_rigid_run(tmp_path / "rigid")
    v = read_mp4(
        render_run(
            tmp_path / "rigid",
            tmp_path / "r.mp4",
            width=W,
            height=H,
            camera={"azimuth_deg": 135.0, "elevation_deg": -45.0},
        )
    )
    assert v.shape == (6, H, W, 3)
    assert all(f.std() > 10 for f in v)
    assert not np.array_equal(v[0], v[-1])
    with pytest.raises(ValueError, match="exaggeration"):
        render_run(tmp_path / "rigid", tmp_path / "r2.mp4", width=W, height=H, exaggeration=5.0)
    assert not (tmp_path / "r2.mp4").exists()


def test_exaggeration_scales_out_of_plane_deviation(tmp_path, gl):
    """k scales each node's deviation from its layer's mean offset; layer spacing is kept."""
    bend = 0.2
    info = write_truss_run(tmp_path / "bent", T=2, bend_m=bend, activity=False)
    lat = info["lattice"]
    run = load_run(tmp_path / "bent")
    k = 5.0
    with RunScene(run, width=W, height=H) as scene:
        scene.prepare(np.array([0]), exaggeration=k)
        from magsail_mj.render.compose import CameraView

        image = scene.render(0, view=CameraView(distance_m=scene.auto_distance_m))
        z = scene.data.xpos[1 : lat.n_nodes + 1, 2].copy()  # record 0: no rotation
        site_z = scene.data.site_xpos[:, 2].copy()
    assert image.std() > 10
    ref = lat.nodes[:, 2]
    w = bend * (lat.nodes[:, 0] ** 2 + lat.nodes[:, 1] ** 2) / (lat.side_m / 2) ** 2
    top, bottom = lat.top_nodes, lat.bottom_nodes
    for layer in (top, bottom):
        dev = w[layer] - w[layer].mean()
        expected = ref[layer] + w[layer].mean() + k * dev
        assert np.allclose(z[layer], expected, atol=1e-9)
    assert np.isclose(z[top].mean() - z[bottom].mean(), lat.cube_edge_m)  # thickness kept
    assert np.allclose(site_z, z)  # struts follow


def test_render_errors_name_the_argument(tmp_path):
    write_truss_run(tmp_path / "run")
    with pytest.raises(ValueError, match="width"):
        render_run(tmp_path / "run", tmp_path / "x.mp4", width=321)
    with pytest.raises(ValueError, match="out_path"):
        render_run(tmp_path / "run", tmp_path / "x.gif")
    with pytest.raises(RenderError, match="compare: no such folder"):
        render_run(tmp_path / "run", tmp_path / "x.mp4", compare=tmp_path / "missing")
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    manifest["render"]["overlay"] = ["no_such_series_m", "surface_sd_m"]
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.warns(RuntimeWarning, match="no_such_series_m"):  # drawn without it
        assert list(load_run(tmp_path / "run").series) == ["surface_sd_m"]
    manifest["render"]["overlay"] = "surface_sd_m"
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(RenderError, match="overlay: expected a list"):
        load_run(tmp_path / "run")
    manifest["render"]["overlay"] = []
    manifest["render"]["camera"] = {"zoom": 2}
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="camera"):
        load_run(tmp_path / "run")
    assert not (tmp_path / "x.mp4").exists()


def test_diverged_run_is_rendered_up_to_the_blow_up(tmp_path):
    write_truss_run(tmp_path / "run")
    with np.load(tmp_path / "run" / "timeseries.npz") as npz:
        arrays = dict(npz)
    arrays["qpos"][-2:, 5] = np.nan
    np.savez(tmp_path / "run" / "timeseries.npz", **arrays)
    with pytest.warns(RuntimeWarning, match="non-finite from record 7"):
        run = load_run(tmp_path / "run")
    assert run.t.size == T_FRAMES - 2 and run.qpos.shape[0] == T_FRAMES - 2
    assert run.strut_activity.shape[0] == T_FRAMES - 2
    assert run.series["surface_sd_m"].shape == (T_FRAMES - 2,)


def test_inset_plots_the_named_series_up_to_the_frame(tmp_path, gl):
    """manifest.render.inset draws the series' history in the lower left corner; the curve grows
    with time (later frames have more plot pixels there); a bad name is refused by name."""
    write_truss_run(tmp_path / "run", activity=False)
    plain = read_mp4(render_run(tmp_path / "run", tmp_path / "plain.mp4", width=W, height=H))
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    manifest["render"]["inset"] = "surface_sd_m"
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    v = read_mp4(render_run(tmp_path / "run", tmp_path / "inset.mp4", width=W, height=H))
    corner = (slice(H // 2, H), slice(0, W // 2))
    assert np.abs(v[0][corner].astype(int) - plain[0][corner]).mean() > 5  # the box is drawn
    # orange: red well above blue (the 2 px line's chroma is halved by yuv420p, so no fixed level)
    rgb = [f[corner].astype(int) for f in v]
    curve = [int(np.count_nonzero((c[..., 0] > 140) & (c[..., 0] - c[..., 2] > 60))) for c in rgb]
    assert curve[-1] > curve[0] + 50, curve  # orange line grows
    manifest["render"]["inset"] = "qpos"
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="inset"):
        load_run(tmp_path / "run")


# --------------------------------------------------------------------------- every scenario kind

_FAST_LATTICE = ["lattice.units=3", "sim.duration_s=0.5", "sim.record_every=2"]
#: One shipped config per scenario kind (``scenario``/``kind`` in models/**/*.toml), cut to a few steps.
SCENARIO_KINDS = [
    ("cnusail/attitude", "magsail_mj/concepts/cnusail/configs/detumble_pre.toml", ["sim.duration_s=1"]),
    ("msac/lumped", "magsail_mj/concepts/msac/configs/lumped.toml", []),
    (
        "msac/multibody",
        "magsail_mj/concepts/msac/configs/paper_1khz.toml",
        ["sim.duration_s=0.02", "sim.record_every=200"],
    ),  # noqa: E501
    (
        "msac/sweep",
        "magsail_mj/concepts/msac/configs/sweeps/stroke.toml",
        ["sim.duration_s=0.02", "sim.record_every=200"],
    ),  # noqa: E501
    (
        "reflector/detumble",
        "magsail_mj/concepts/reflector/configs/detumble.toml",
        ["sim.duration_s=2", "sim.record_every=2"],
    ),  # noqa: E501
    (
        "reflector/pitch",
        "magsail_mj/concepts/reflector/configs/tracking_10g.toml",
        ["sim.duration_s=2", "sim.record_every=1"],
    ),  # noqa: E501
    (
        "reflector/pitch_caps",
        "magsail_mj/concepts/reflector/configs/pitch/b3_caps_sigma10.toml",
        ["sim.duration_s=2", "sim.record_every=1"],
    ),  # noqa: E501
    ("current_loops/sweep", "magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml", _FAST_LATTICE),
    ("current_loops/slew", "magsail_mj/concepts/current_loops/configs/slew.toml", _FAST_LATTICE),
    ("current_loops/slew_rigid", "magsail_mj/concepts/current_loops/configs/slew_rigid.toml", _FAST_LATTICE),
    (
        "truss/dist_vs_central",
        "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.toml",
        _FAST_LATTICE,
    ),  # noqa: E501
    ("truss/cantilever", "magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml", _FAST_LATTICE),
    ("truss/free", "magsail_mj/concepts/truss_magnetorquer/configs/libration.toml", _FAST_LATTICE),
    ("truss/detumble", "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", _FAST_LATTICE),
    ("truss/slew", "magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml", _FAST_LATTICE),
]


@pytest.mark.parametrize("kind, config, overrides", SCENARIO_KINDS)
def test_every_scenario_kind_renders_its_video(tmp_path, gl, monkeypatch, kind, config, overrides):
    """A short run of each scenario kind with video=True writes a playable video.mp4 (the truss
    cantilever used to fail: its render table names an overlay series it does not record) and
    figures that pass the readability check (tests/test_plots.py; the run fails on a bad one)."""
    monkeypatch.setenv(CHECK_ENV, "1")
    cfg = load_config(REPO / config, overrides)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        outcome = run_scenario(cfg, tmp_path / "run", video=True, progress=False)
    video = tmp_path / "run" / "video.mp4"
    assert video.is_file(), (kind, outcome.status, outcome.get("status_message"))
    frames = read_mp4(video)
    assert frames.shape[0] >= 1 and frames.shape[1:] == (540, 960, 3), frames.shape
    assert frames.std() > 1.0  # not a blank image


def test_run_without_positions_is_refused_by_name(tmp_path):
    """The CNUSAIL lifetime kind records no motion (no 'qpos'): rendering it is a RenderError that
    names run_dir, the file and the series, before any GL context is made."""
    write_truss_run(tmp_path / "run")
    with np.load(tmp_path / "run" / "timeseries.npz") as npz:
        arrays = {k: v for k, v in npz.items() if k != "qpos"}
    np.savez(tmp_path / "run" / "timeseries.npz", **arrays)
    with pytest.raises(RenderError, match=r"run_dir: .*timeseries.npz: series 'qpos' is missing"):
        render_run(tmp_path / "run", tmp_path / "x.mp4")
    (tmp_path / "run" / "timeseries.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(RenderError, match="cannot read"):
        load_run(tmp_path / "run")
    assert not (tmp_path / "x.mp4").exists()


def test_render_output_path_is_checked_before_rendering(tmp_path):
    write_truss_run(tmp_path / "run")
    (tmp_path / "file").write_text("x")
    (tmp_path / "dir.mp4").mkdir()
    for out, match in (
        (tmp_path / "x.avi", "only MP4"),
        ("", "empty path"),
        (tmp_path / "dir.mp4", "is a folder"),
        (tmp_path / "file" / "x.mp4", "is a file"),
    ):
        with pytest.raises(RenderError, match=f"out_path: .*{match}"):
            render_run(tmp_path / "run", out)
    with pytest.raises(RenderError, match="run_dir: must be a run folder, got an empty path"):
        render_run("", tmp_path / "x.mp4")
    with pytest.raises(RenderError, match="run_dir: is a file"):
        render_run(tmp_path / "file", tmp_path / "x.mp4")


def test_render_memory_is_estimated_before_loading(tmp_path):
    """A render needing more than the limit is refused with the estimate and the limit."""
    write_truss_run(tmp_path / "run")
    with memory_limit(1 << 20), pytest.raises(MemoryLimitError, match=r"render .*needs about .*limit of 1 MiB"):
        render_run(tmp_path / "run", tmp_path / "x.mp4", width=W, height=H)
    assert not (tmp_path / "x.mp4").exists()


# --------------------------------------------------------------------------- legend and overlay text


def test_overlay_values_have_names_units_and_enumeration_meanings():
    from magsail_mj.render.overlay import format_time, format_value, series_name_unit

    assert series_name_unit("omega_norm_deg_s") == ("omega norm", "°/s")
    assert series_name_unit("wheel_speed_rpm") == ("wheel speed", "rpm")
    assert series_name_unit("time_h") == ("time", "h")
    assert series_name_unit("phase") == ("phase", "")
    assert format_value("surface_sd_m", 5.1e-4) == "surface sd = 510 µm"
    assert format_value("torque_norm_Nm", 2.5) == "torque norm = 2.5 N m"
    assert (
        format_value("theta_e_deg", 12.5, names={"theta_e_deg": "attitude error θ_e"}) == "attitude error θ_e = 12.5°"
    )
    assert format_value("wheel_speed_rpm", [1.0, -2.0, 3.0]) == "wheel speed (x, y, z) = [1, -2, 3] rpm"
    labels = {"mode": {"0": "detumbling", "1": "nadir pointing"}}
    assert format_value("mode", 1, labels=labels) == "mode: nadir pointing"
    assert format_value("mode", 7, labels=labels) == "mode = 7"  # not in the table: the number
    assert format_value("count", 3, units={"count": "rods"}) == "count = 3 rods"
    assert format_time(5.0) == "t = 5 s" and format_time(600.0) == "t = 600.0 s (10.0 min)"
    assert format_time(7200.0) == "t = 7200.0 s (2.00 h)"


def test_cnusail_mode_and_msac_phase_are_printed_by_name():
    """Every value of the CNUSAIL controller's Mode and of the MSAC cycle phase has a meaning in
    the task's render table (the recorded 'mode' and 'phase' series are enumerations)."""
    from magsail_mj.concepts import build_task
    from magsail_mj.concepts.cnusail.modes import Mode
    from magsail_mj.render.overlay import format_value

    cn = build_task(load_config(REPO / "magsail_mj/concepts/cnusail/configs/deorbit_recalc.toml"))
    info = cn.render_info()
    texts = {m: format_value("mode", int(m), names=info["overlay_names"], labels=info["overlay_labels"]) for m in Mode}
    assert texts[Mode.DETUMBLE] == "mode: detumbling (B-dot, wheels idle)"
    assert texts[Mode.NADIR] == "mode: nadir pointing, eigen-axis law"
    assert texts[Mode.DEORBIT].startswith("mode: deorbit attitude")
    ms = build_task(load_config(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml"))
    phases = ms.render_info()["overlay_labels"]["phase"]
    assert phases == {
        "1": "1 of 4, bend (extended)",
        "2": "2 of 4, contract",
        "3": "3 of 4, bend back (contracted)",
        "4": "4 of 4, extend",
    }


def test_every_marker_of_a_deployed_cnusail_and_msac_names_model_objects():
    """The legend rows come from the model: each render.markers key of the CNUSAIL (deployed) and
    MSAC tasks matches objects of the task's model, with their colours (body axes: three)."""
    from magsail_mj.concepts import build_task
    from magsail_mj.render.compose import _ModelColours

    for config in ("cnusail/configs/deorbit_recalc.toml", "msac/configs/paper_1khz.toml"):
        task = build_task(load_config(REPO / "magsail_mj/concepts" / config))
        colours = _ModelColours(task.model)
        for key, text in task.render_info()["markers"].items():
            entry = colours.entry(key, text)
            assert entry is not None, (config, key)
            assert entry.text == text and 1 <= len(entry.colours) <= 3
    cn = build_task(load_config(REPO / "magsail_mj/concepts/cnusail/configs/deorbit_recalc.toml"))
    axes = _ModelColours(cn.model).entry("axis_x/y/z", "body axes")
    rgba = {n: tuple(round(float(c), 3) for c in cn.model.geom(n).rgba[:3]) for n in ("axis_x", "axis_y", "axis_z")}
    assert axes.colours == (rgba["axis_x"], rgba["axis_y"], rgba["axis_z"])
    assert _ModelColours(cn.model).entry("no_such_object", "x") is None


def test_render_tables_are_checked_by_name(tmp_path):
    write_truss_run(tmp_path / "run")
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    manifest["render"]["overlay_labels"] = {"mode": "detumbling"}
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(RenderError, match=r"render.overlay_labels.mode: expected a table"):
        load_run(tmp_path / "run")
    manifest["render"]["overlay_labels"] = {"mode": {0: "detumbling"}}
    manifest["render"]["markers"] = {"n0": ["not", "a", "text"]}
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(RenderError, match=r"render.markers.n0: expected a text"):
        load_run(tmp_path / "run")
    manifest["render"]["markers"] = {"n0": "first node"}
    (tmp_path / "run" / "manifest.json").write_text(json.dumps(manifest))
    run = load_run(tmp_path / "run")
    assert run.labels == {"mode": {"0": "detumbling"}} and run.markers == {"n0": "first node"}
    assert run.identity == "scenario render_test · config test"


def test_identity_comes_from_the_record_store_before_the_manifest_exists(tmp_path):
    """A run renders its video before it writes manifest.json: the scenario and the config hash in
    the corner are then read from the record store's attributes (first 12 hex digits)."""
    from magsail_mj.records import STORE_NAME, write_group

    write_rigid_run(tmp_path / "run")
    with np.load(tmp_path / "run" / "timeseries.npz") as npz:
        arrays = dict(npz)
    (tmp_path / "run" / "timeseries.npz").unlink()
    (tmp_path / "run" / "manifest.json").unlink()
    write_group(
        tmp_path / "run" / STORE_NAME,
        arrays,
        n_time=arrays["t"].size,
        attrs={"scenario": "slew", "config_hash": "0123456789abcdef" * 4},
    )
    run = load_run(tmp_path / "run", render_info={"title": "x"})
    assert run.identity == "scenario slew · config 0123456789ab"


def _swatch_pixels(frame: np.ndarray, rgb: tuple[float, float, float], region) -> int:
    target = np.array([round(255 * c) for c in rgb])
    return int(np.count_nonzero(np.abs(frame[region].astype(int) - target).max(axis=-1) < 12))


def test_legend_shows_a_swatch_of_each_marker_colour(tmp_path, gl):
    """A render.markers entry draws a swatch of its object's colour in the top right corner; the
    frame without the entry has no swatch there."""
    from magsail_mj.render.compose import render_frames

    write_rigid_run(tmp_path / "rigid")
    region = (slice(0, 540 // 2), slice(960 // 2, 960))
    panel_colour = (0.2, 0.3, 0.8)  # the rigid satellite's panels
    plain = next(render_frames(tmp_path / "rigid", max_frames=1, camera={"distance_m": 50.0}))
    keyed = next(
        render_frames(
            tmp_path / "rigid",
            max_frames=1,
            camera={"distance_m": 50.0},
            render_info={"title": "rigid sat", "markers": {"bus": "bus and panels"}},
        )
    )
    # a 14 px square at 960 x 540 (196 px; the far-away model itself shows a few of that colour)
    assert _swatch_pixels(keyed, panel_colour, region) >= _swatch_pixels(plain, panel_colour, region) + 100


# --------------------------------------------------------------------------- why a run ended


def test_end_reason_names_the_cause_and_the_time():
    """The line a picture prints where a run stops: the failed strut and its strain, the time of
    a divergence, a stop or an interrupt."""
    failed = {
        "status": "structure_failed",
        "status_message": "strut 1330 strain 0.501 exceeds sim.max_strain 0.5 at t = 646 s",
        "t_end_s": 646.0,
    }
    assert end_reason(failed) == "structure failed at 646 s: strut 1330 strain 0.501 > 0.5"
    post = {
        "status": "structure_failed",
        "status_message": "the structure failed at t = 81.0 s (post-processing found inverted cells)",
        "strut_strain_max": 0.61234,
        "t_end_s": 100.0,
    }
    assert end_reason(post) == "structure failed at 81 s: largest strut strain 0.612"
    diverged = {
        "status": "diverged",
        "status_message": "MuJoCo BADQACC at t = 12.3 s: an acceleration is not finite or huge (unstable step)",
    }
    assert end_reason(diverged) == "diverged at 12.3 s: MuJoCo BADQACC: an acceleration is not finite or huge"
    nan = {"status": "diverged", "status_message": "state is not finite at t = 7.5 s (after the step from t = 7.4 s)"}
    assert end_reason(nan) == "diverged at 7.5 s: state is not finite"
    stopped = {"status": "stopped", "status_message": "stopped at t = 300 s (stop_after_s)", "t_end_s": 300.0}
    assert end_reason(stopped) == "stopped at 300 s"
    assert end_reason({"status": "interrupted", "status_message": "interrupted at t = 41 s"}) == "interrupted at 41 s"
    assert end_reason({"status": "completed", "t_end_s": 600.0}) == "completed at 600 s"
    assert end_reason({}, t_last_s=40.0) == "run ended at 40 s"


def test_video_says_why_a_run_ended(tmp_path, gl, monkeypatch):
    """Side by side, the shorter run's panel prints why it ended (from its summary.json) once the
    video is past its last record, and not before; a run that completed prints nothing."""
    write_truss_run(tmp_path / "long", activity=False)
    write_truss_run(tmp_path / "short", T=5, duration_s=40.0, activity=False)
    message = "strut 12 strain 0.501 exceeds sim.max_strain 0.5 at t = 40 s"
    (tmp_path / "short" / "summary.json").write_text(
        json.dumps({"status": "structure_failed", "status_message": message, "t_end_s": 40.0})
    )
    (tmp_path / "long" / "summary.json").write_text(json.dumps({"status": "completed", "t_end_s": 80.0}))
    drawn: list[dict] = []
    original = compose.draw_overlay

    def record(image, text, **kwargs):
        drawn.append({**kwargs, "text": text, "end_line": text.end_line})
        return original(image, text, **kwargs)

    monkeypatch.setattr(compose, "draw_overlay", record)
    frames = list(render_frames(tmp_path / "long", compare=tmp_path / "short", width=96, height=54, antialias=False))
    assert len(frames) == T_FRAMES
    left, right = drawn[0::2], drawn[1::2]
    reason = "structure failed at 40 s: strut 12 strain 0.501 > 0.5"
    assert [d["ended"] for d in right] == [False] * 4 + [True] * 5  # its last record is at 40 s
    assert all(d["end_line"] == reason for d in right)
    assert not any(d["ended"] for d in left)
    # alone, the failed run prints it on its last frame (where the video stops)
    drawn.clear()
    assert len(list(render_frames(tmp_path / "short", width=96, height=54, antialias=False))) == 5
    assert [d["ended"] for d in drawn] == [False] * 4 + [True]
    # the overlay prints it: the panel differs from one drawn without the reason
    image = np.zeros((54, 96, 3), np.uint8)
    last = right[-1]
    args = {"time_s": last["time_s"], "values": last["values"], "ended": True}
    plain = dataclasses.replace(last["text"], end_line="")
    assert not np.array_equal(original(image, last["text"], **args), original(image, plain, **args))


# --------------------------------------------------------------------------- framing


def test_free_rectangles_avoid_every_box():
    boxes = [(0, 0, 50, 20), (70, 70, 100, 100)]
    rects = free_rectangles(100, 100, boxes, margin=2)
    assert rects
    for x0, y0, x1, y1 in rects:
        assert 2 <= x0 < x1 <= 98 and 2 <= y0 < y1 <= 98
        for b in boxes:
            assert b[2] + 2 <= x0 or b[0] - 2 >= x1 or b[3] + 2 <= y0 or b[1] - 2 >= y1
    assert (2, 22, 98, 68) in rects  # the band between the boxes, full width
    assert free_rectangles(100, 100, [(0, 0, 100, 100)], margin=2) == []


def _structure_bbox(image: np.ndarray) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the pixels the rendered structure covers (the background is black)."""
    ys, xs = np.nonzero(image.max(axis=-1) > 40)
    assert xs.size, "nothing rendered"
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


@pytest.mark.parametrize(
    ("units", "side_m", "bend_m", "render", "compare"),
    [
        (1, 2.0, 0.0, {}, None),  # a single cube
        (3, 10.0, 2.0, {"exaggeration": 4.0, "inset": "surface_sd_m"}, None),  # bent and exaggerated
        # a large truss with a manifest distance far too close (the detumble at lattice.units=5)
        (6, 80.0, 0.0, {"camera": {"distance_m": 5.0}, "inset": "torque_cmd_Nm"}, None),
        (2, 4.0, 0.5, {"inset": "surface_sd_m"}, (5, 60.0)),  # side by side: small beside large
    ],
)
def test_structure_stays_clear_of_the_overlay(tmp_path, gl, monkeypatch, units, side_m, bend_m, render, compare):
    """Every frame draws the whole structure inside the panel and outside every part of the
    overlay (title, values, legend, colour bar, inset, identity, label), whatever its size and
    the recorded motion."""
    title = "a long title that takes much of the width of the panel"
    write_truss_run(tmp_path / "a", units=units, side_m=side_m, bend_m=bend_m, T=5, title=title, render=render)
    options: dict = {"width": 192, "height": 108, "antialias": False}
    if compare is not None:
        write_truss_run(tmp_path / "b", units=compare[0], side_m=compare[1], T=5, activity=False)
        options["compare"] = tmp_path / "b"
    drawn: list[tuple[np.ndarray, dict]] = []
    original = compose.draw_overlay

    def record(image, text, **kwargs):
        drawn.append((image.copy(), text, kwargs))  # the rendered structure, before the overlay
        return original(image, text, **kwargs)

    monkeypatch.setattr(compose, "draw_overlay", record)
    frames = list(render_frames(tmp_path / "a", **options))
    assert len(frames) == 5 and len(drawn) == 5 * (1 + (compare is not None))
    areas = []
    for image, text, kw in drawn:
        h, w = image.shape[:2]
        x0, y0, x1, y1 = _structure_bbox(image)
        assert 0 < x0 and 0 < y0 and x1 < w and y1 < h, f"structure at {(x0, y0, x1, y1)} leaves the panel"
        boxes = overlay_boxes(w, h, text, lines=[format_time(kw["time_s"]), *kw["values"]], ended=kw["ended"])
        for b in boxes:
            clear = b[2] <= x0 or b[0] >= x1 or b[3] <= y0 or b[1] >= y1
            assert clear, f"structure at {(x0, y0, x1, y1)} runs under the overlay box {b}"
        areas.append((x1 - x0) * (y1 - y0) / (w * h))
    # one camera for both panels: the larger structure sets the distance and is not drawn tiny
    largest = np.max(np.reshape(areas, (5, -1)), axis=1)
    assert np.all(largest > 0.02), f"the structure is drawn too small: {largest}"


def test_readme_picture_is_the_video_frame_where_the_left_run_ended(tmp_path, gl):
    """scripts/readme_picture.py (the main job's last step) writes the side-by-side video's frame
    at the centralised run's end, found by the renderer's frame plan."""
    runs = tmp_path / "runs"
    write_truss_run(runs / "case_c_distributed_bangbang", activity=False)
    write_truss_run(runs / "case_c_central_bangbang", T=5, duration_s=40.0, activity=False)
    (runs / "case_c_central_bangbang" / "summary.json").write_text(
        json.dumps({"status": "structure_failed", "status_message": "strut 3 strain 0.6 exceeds sim.max_strain 0.5"})
    )
    video = render_run(
        runs / "case_c_central_bangbang",
        runs / "case_c_bangbang_side_by_side.mp4",
        compare=runs / "case_c_distributed_bangbang",
        width=96,
        height=54,
        antialias=False,
    )
    script = load_file_module("scripts", "readme_picture")
    out = tmp_path / "picture.png"
    assert script.main(["--runs", str(runs), "--out", str(out), "--width", "0"]) == 0
    with Image.open(out) as img:
        picture = np.asarray(img.convert("RGB")).astype(int)
    frames = read_mp4(video).astype(int)
    # frame 4 (t = 40 s, the central run's last record), within the 256-colour palette's rounding
    errors = [np.abs(picture - f).mean() for f in frames]
    assert int(np.argmin(errors)) == 4 and errors[4] < 3, errors
    assert script.main(["--runs", str(tmp_path / "none"), "--out", str(out)]) == 2


def test_render_memory_counts_the_records_read_from_the_store(tmp_path):
    """A run's records are read from its store a chunk's rows at a time: the estimate counts that
    block twice per run (the chunk kept and the one read), so a limit that covers everything else
    but not those blocks is refused."""
    from magsail_mj.records import chunk_block_bytes, lazy_arrays, write_group
    from magsail_mj.resources import mjcf_model_bytes, render_bytes

    written = write_truss_run(tmp_path / "run")
    folder = tmp_path / "run"
    write_group(folder / "timeseries.zarr", {"t": written["t"], "qpos": written["qpos"]}, n_time=len(written["t"]))
    (folder / "timeseries.npz").unlink()
    block = chunk_block_bytes(lazy_arrays(folder))
    assert block == written["qpos"].nbytes  # one chunk holds the short run
    model_bytes, nbody = mjcf_model_bytes(folder / "model.xml")
    common = dict(frames=10, width=W, height=H, panels=1, nbody=nbody, model_bytes=model_bytes)
    without, with_block = render_bytes(**common), render_bytes(**common, records_block_bytes=block)
    assert with_block == without + 2 * block
    with memory_limit(int(without) + 1), pytest.raises(MemoryLimitError, match="render"):
        compose._check_render_memory([folder], max_frames=10, width=W, height=H)
    with memory_limit(int(with_block) + 1):
        compose._check_render_memory([folder], max_frames=10, width=W, height=H)
