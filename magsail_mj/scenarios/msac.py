r"""The MSAC concept (``msac``): config schema, scenario wiring, summary and plots.

Spec ``msac.md``. A bus turns itself with no wheels and no external torque by bending its two
point-symmetric wings one way while they are extended and back while they are contracted
(§0, §2). Scenario ids (§5.5):

* ``lumped`` — analytic only: Eqs. (6)–(7) (with the §3.2 sign correction) and the exact planar
  model (§3.3) for the configured geometry; no MuJoCo steps.
* ``multibody`` — the MuJoCo model driven along the cycle (``paper_1khz``,
  ``paper_1khz_stroke10``, ``slow_1hz``, ``lumped_limit``, ``mirror_wings`` …).
* ``sweep`` — a base config plus a ``[sweep]`` table: the listed keys are set to each point's
  values and the multibody run and the references are evaluated per point (F6, F7).

Frames: the MuJoCo world is inertial (free space, gravity off, no orbit, §1). The bus yaw ``ψ``
is about world Z; the wing angle ``φ`` is the hinge angle relative to the bus; ``s`` the slide
of the whole rigid wing (``extension_model = "rigid_slide"``). Units SI; config angles in
degrees at the edge (``*_deg``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
from pydantic import Field, model_validator

from magsail_mj.analysis.msac_post import (
    cycle_increments, filtered_rate, secular_rate_fit, unwrapped_yaw,
)
from magsail_mj.analysis.msac_reference import (
    PlanarMsac, exact_rotation_path, exact_rotation_samples, lumped_theta, wing_inertias,
)
from magsail_mj.config import MAX_STEPS, MJ_MINVAL, ConfigError, ConfigProblem, SimConfig, StrictModel
from magsail_mj.config import parse_config, register_concept
from magsail_mj.control.msac_cycle import CyclePath, cycle_state
from magsail_mj.control.msac_drive import steps_per_cycle
from magsail_mj.mjcf.msac import MsacModelParams, build_msac_spec
from magsail_mj.scenarios import register_builder
from magsail_mj.sim import RunResult

__all__ = ["MsacConfig", "MsacScenario", "build_msac_scenario", "PAPER_VALUES", "point_config"]

Vec3 = tuple[float, float, float]

#: Inputs the paper states (spec §5.1); every other physical parameter is a placeholder (§5.2).
PAPER_VALUES: dict[str, Any] = {
    "wings.length_m": 8.0,
    "wings.width_m": 3.0,
    "wings.count": 2,
    "cycle.frequency_Hz": 1000.0,
    "cycle.bend_a_deg": 10.0,
    "cycle.extension_frac": 0.01,
    "cycle.contraction_frac": 0.0,
    "sim.duration_s": 600.0,
}
PLACEHOLDERS = ("bus.mass_kg", "bus.size_m", "bus.inertia_scale", "wings.thickness_m",
                "wings.areal_density_kg_m2", "wings.hinge_offset_m", "cycle.bend_b_deg",
                "cycle.phase_fractions", "cycle.blend", "wings.slide_stiffness_N_m",
                "wings.root_mass_kg", "wings.root_inertia_kg_m2")


class BusConfig(StrictModel):
    """``[bus]``: uniform box (spec §5.2 placeholders).

    ``inertia_scale`` multiplies all three box moments (only ``I_zz`` enters the planar motion;
    scaling all three keeps the inertia physically valid, e.g. ×1000 for the lumped limit T5).
    """

    mass_kg: float = Field(default=3000.0, gt=0)
    size_m: Vec3 = (2.0, 2.0, 3.0)
    inertia_scale: float = Field(default=1.0, gt=0)

    @model_validator(mode="after")
    def _positive(self) -> BusConfig:
        if any(not x > 0 for x in self.size_m):
            raise ValueError(f"size_m: every edge must be > 0, got {list(self.size_m)}")
        return self


class WingsConfig(StrictModel):
    """``[wings]``: two rigid wings, each one rigid slide + one hinge (spec §5.2, §5.4).

    ``hinge_offset_m`` is ``r0`` (default: the ±X face of the 2 m bus). ``layout = "mirror"``
    only for the negative test T4. ``root_*``: the hinge-body placeholder inertial (above
    mjMINVAL = 1e-15). The wing mass σ ℓ w and its plate inertias must exceed mjMINVAL too
    (checked with the whole config).
    """

    count: Literal[2] = 2
    layout: Literal["point_symmetric", "mirror"] = "point_symmetric"
    length_m: float = Field(default=8.0, gt=0)
    width_m: float = Field(default=3.0, gt=0)
    thickness_m: float = Field(default=0.03, gt=0)
    areal_density_kg_m2: float = Field(default=2.5, gt=0)
    hinge_offset_m: float = Field(default=1.0, ge=0)
    extension_model: Literal["rigid_slide"] = "rigid_slide"
    slide_stiffness_N_m: float = Field(default=0.0, ge=0)
    root_mass_kg: float = Field(default=1e-3, gt=MJ_MINVAL)
    root_inertia_kg_m2: float = Field(default=1e-6, gt=MJ_MINVAL)


class CycleConfig(StrictModel):
    """``[cycle]``: the four-phase path (spec §2, §5.5).

    ``s_e = extension_frac·ℓ``, ``s_c = −contraction_frac·ℓ`` (the rest length is ``s = 0``).
    ``phase_fractions`` are ``(t_be, t_c, t_bc, t_e)/Δt``. ``pattern`` selects the T2/T3 test
    paths (``msac``, ``reversed``, ``bend_only``, ``extend_only``).
    """

    frequency_Hz: float = Field(default=1000.0, gt=0)
    bend_a_deg: float = Field(default=10.0, ge=-90, le=90)
    bend_b_deg: float = Field(default=-10.0, ge=-90, le=90)
    extension_frac: float = Field(default=0.01, ge=0, le=0.5)
    contraction_frac: float = Field(default=0.0, ge=0, le=0.5)
    phase_fractions: tuple[float, float, float, float] = (0.4, 0.1, 0.4, 0.1)
    blend: Literal["min_jerk", "cubic", "cosine"] = "min_jerk"
    pattern: Literal["msac", "reversed", "bend_only", "extend_only"] = "msac"

    @model_validator(mode="after")
    def _fractions(self) -> CycleConfig:
        if any(not f > 0 for f in self.phase_fractions) or abs(sum(self.phase_fractions) - 1) > 1e-9:
            raise ValueError(f"phase_fractions: need four values > 0 summing to 1, got {list(self.phase_fractions)}")
        return self


class DriveConfig(StrictModel):
    """``[drive]`` (spec §5.3–5.4): ``replay`` = native rollout of a recorded settled
    computed-torque cycle plus joint servos; ``computed_torque`` = Python loop per step.
    ``momentum_projection``: zero the total momentum every ``chunk_cycles`` cycles, removing
    RK4's drift (see :mod:`magsail_mj.scenarios.msac_runner`)."""

    method: Literal["replay", "computed_torque"] = "replay"
    omega_c_dt: float = Field(default=0.2, gt=0, le=1.0)
    servo_omega_dt: float = Field(default=0.05, gt=0, le=0.5)
    calibration_cycles: int = Field(default=3, ge=2)
    chunk_cycles: int = Field(default=200, ge=1)
    momentum_projection: bool = True


class PostConfig(StrictModel):
    """``[post]`` (spec §6): discarded start-up cycles, low-pass filter, edge discard, windows."""

    discard_cycles: int = Field(default=1, ge=0)
    lowpass_order: int = Field(default=4, ge=1, le=10)
    lowpass_cutoff_Hz: float = Field(default=10.0, gt=0)
    edge_discard_s: float = Field(default=1.0, ge=0)
    min_filter_duration_s: float = Field(default=5.0, gt=0)
    window_s: float = Field(default=0.02, gt=0)
    omega_sample_Hz: float = Field(default=20000.0, gt=0)


class RenderConfig(StrictModel):
    """``[render]``: camera looking down world Z (elevation −89.9° avoids the pole), video
    options and the *visual-only* exaggeration of the extension used by the V1 video."""

    azimuth_deg: float = 90.0
    elevation_deg: float = -89.9
    distance_m: float | None = Field(default=None, gt=0)
    fps: int = Field(default=30, ge=1, le=120)
    max_frames: int = Field(default=600, ge=2)
    extension_exaggeration: float = Field(default=10.0, ge=1)


class SweepConfig(StrictModel):
    """``[sweep]``: ``keys`` are dotted config keys; each entry of ``points`` gives their values.

    ``base`` names the scenario id the sweep starts from (``models/msac/<base>.toml``; a test
    checks the file's other tables equal it). ``cycles`` sets each point's duration;
    ``keep_steps_per_cycle`` rescales ``sim.timestep_s`` with the cycle period so that every
    point has the base's steps per cycle (frequency sweeps, spec T6).
    """

    base: str
    keys: list[str] = Field(min_length=1)
    points: list[list[Any]] = Field(min_length=1)
    cycles: int = Field(default=20, ge=3)
    keep_steps_per_cycle: bool = True

    @model_validator(mode="after")
    def _shapes(self) -> SweepConfig:
        for i, p in enumerate(self.points):
            if len(p) != len(self.keys):
                raise ValueError(f"points[{i}]: needs {len(self.keys)} value(s) for keys {self.keys}, got {p!r}")
        return self


@register_concept("msac")
class MsacConfig(StrictModel):
    """An MSAC scenario config (``models/msac/*.toml``)."""

    concept: Literal["msac"]
    scenario: Literal["lumped", "multibody", "sweep"]
    description: str = ""
    sim: SimConfig
    bus: BusConfig = BusConfig()
    wings: WingsConfig = WingsConfig()
    cycle: CycleConfig = CycleConfig()
    drive: DriveConfig = DriveConfig()
    post: PostConfig = PostConfig()
    render: RenderConfig = RenderConfig()
    sweep: SweepConfig | None = None

    @model_validator(mode="after")
    def _consistent(self) -> MsacConfig:
        if (self.scenario == "sweep") != (self.sweep is not None):
            raise ConfigProblem("scenario", "a [sweep] table goes with scenario = 'sweep' and only with it",
                                others=("sweep",))
        if self.scenario != "lumped":
            self._check_steps_per_cycle()
        if self.sweep is not None:
            flat = _flatten(self.model_dump(mode="json", exclude={"sweep"}))
            bad = [k for k in self.sweep.keys if k not in flat]
            if bad:
                raise ValueError(f"sweep.keys: {bad} are not config keys (e.g. 'cycle.extension_frac')")
            self._check_points()
        return self

    def _check_points(self) -> None:
        """Every sweep point must give a valid multibody config (validated as it will be run)."""
        sw = self.sweep
        problems = []
        for i, values in enumerate(sw.points):
            try:
                point_config(self, sw.keys, values, cycles=sw.cycles, keep_steps_per_cycle=sw.keep_steps_per_cycle)
            except ConfigError as err:
                problems += [f"sweep.points[{i}]: {line} (from sweep.keys = {sw.keys}, values {values}, "
                             f"sweep.cycles = {sw.cycles})" for line in err.problems]
        if problems:
            raise ValueError("; ".join(problems))

    def _check_steps_per_cycle(self) -> None:
        """The cycle period 1/f must be a whole number (>= 4) of time steps, fewer than 2⁶³."""
        ratio = (1.0 / self.cycle.frequency_Hz) / self.sim.timestep_s
        if not ratio < MAX_STEPS:
            raise ConfigProblem("sim.timestep_s", f"the cycle period 1/cycle.frequency_Hz is {ratio:.3g} time steps, "
                                f"more than a 64-bit step counter holds, got {self.sim.timestep_s!r}",
                                others=("cycle.frequency_Hz",))
        try:
            steps_per_cycle(make_path(self), self.sim.timestep_s)
        except ValueError as err:
            raise ConfigProblem("sim.timestep_s", str(err).removeprefix("timestep_s: "),
                                others=("cycle.frequency_Hz",)) from None

    @model_validator(mode="after")
    def _numbers(self) -> MsacConfig:
        """The bodies MuJoCo receives (bus box, wing plates, hinge bodies) need masses and
        principal inertias above mjMINVAL and finite, and the joint servo gains J ω_s² finite."""
        b, w = self.bus, self.wings
        bus_keys = ("bus.size_m", "bus.inertia_scale")
        a, bb, c = b.size_m
        for name, (p, q) in zip("xyz", ((bb, c), (a, c), (a, bb))):
            _positive_product("bus.mass_kg", b.mass_kg / 12.0 * b.inertia_scale, p * p + q * q,
                              what=f"bus inertia I_{name}", others=bus_keys)
        wing_keys = ("wings.length_m", "wings.width_m", "wings.thickness_m")
        m = _positive_product("wings.areal_density_kg_m2", w.areal_density_kg_m2, w.length_m * w.width_m,
                              what="wing mass σ ℓ w", others=wing_keys)
        l, wd, t = w.length_m, w.width_m, w.thickness_m
        for name, (p, q) in zip("xyz", ((t, wd), (l, wd), (l, t))):
            _positive_product("wings.areal_density_kg_m2", m / 12.0, p * p + q * q,
                              what=f"wing inertia I_{name}", others=wing_keys)
        omega = self.drive.servo_omega_dt / self.sim.timestep_s
        hinge = m * (l * l + t * t) / 12.0 + m * (l / 2) * (l / 2)
        _positive_product("drive.servo_omega_dt", max(hinge, m, 1.0), 2.0 * omega * omega, what="servo gain J ω_s²",
                          others=("sim.timestep_s", "wings.areal_density_kg_m2", *wing_keys))
        return self


def _positive_product(key: str, a: float, b: float, *, what: str, others: tuple[str, ...]) -> float:
    """``a · b``: a :class:`ConfigProblem` on ``key`` when it is not finite or not above mjMINVAL."""
    value = a * b
    if not math.isfinite(value):
        raise ConfigProblem(key, f"makes the {what} overflow float64", others=others)
    if not value > MJ_MINVAL:
        raise ConfigProblem(key, f"makes the {what} {value:.6g}, which must be > {MJ_MINVAL:g} (mjMINVAL)",
                            others=others)
    return value


# ---------------------------------------------------------------------------------- model


def make_path(cfg: MsacConfig) -> CyclePath:
    """The cycle of a config (spec §2): ``φa``, ``φb`` from degrees, ``s`` from fractions of ℓ."""
    c, l = cfg.cycle, cfg.wings.length_m
    return CyclePath(phi_a_rad=math.radians(c.bend_a_deg), phi_b_rad=math.radians(c.bend_b_deg),
                     s_e_m=c.extension_frac * l, s_c_m=-c.contraction_frac * l,
                     period_s=1.0 / c.frequency_Hz, fractions=tuple(c.phase_fractions),
                     blend=c.blend, pattern=c.pattern)


def make_params(cfg: MsacConfig) -> MsacModelParams:
    """Model parameters of a config (wing mass = areal density × ℓ × w)."""
    w = cfg.wings
    return MsacModelParams(
        bus_mass_kg=cfg.bus.mass_kg, bus_size_m=tuple(cfg.bus.size_m), wing_length_m=w.length_m,
        wing_width_m=w.width_m, wing_thickness_m=w.thickness_m,
        wing_mass_kg=w.areal_density_kg_m2 * w.length_m * w.width_m, hinge_offset_m=w.hinge_offset_m,
        layout=w.layout, root_mass_kg=w.root_mass_kg, root_inertia_kg_m2=w.root_inertia_kg_m2,
        slide_stiffness_N_m=w.slide_stiffness_N_m, timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator, solver_tolerance=cfg.sim.solver_tolerance,
        servo_omega_dt=cfg.drive.servo_omega_dt, name=f"msac_{cfg.scenario}")


def planar_model(params: MsacModelParams, *, inertia_scale: float = 1.0) -> PlanarMsac:
    """The exact planar model (spec §3.3) with the MJCF's own inertias (incl. hinge bodies)."""
    return PlanarMsac(bus_izz_kg_m2=float(params.bus_inertia_kg_m2[2]) * inertia_scale,
                      wing_mass_kg=params.wing_mass_kg, wing_length_m=params.wing_length_m,
                      wing_icm_kg_m2=float(params.wing_inertia_cm_kg_m2[2]),
                      hinge_offset_m=params.hinge_offset_m, n_wings=2,
                      root_mass_kg=params.root_mass_kg, root_inertia_kg_m2=params.root_inertia_kg_m2)


def point_config(cfg: MsacConfig, keys: list[str], values: list[Any], *, cycles: int | None = None,
                 keep_steps_per_cycle: bool = True) -> MsacConfig:
    """A multibody config: ``cfg`` with ``keys`` set to ``values`` (validated).

    With ``cycles``, ``sim.duration_s`` becomes ``cycles/f``; with ``keep_steps_per_cycle`` the
    timestep is rescaled so that the steps per cycle of ``cfg`` are kept.
    """
    tree = cfg.model_dump(mode="json")
    tree.pop("sweep", None)
    tree["scenario"] = "multibody"
    n_base = int(round(1.0 / (cfg.cycle.frequency_Hz * cfg.sim.timestep_s)))
    for key, value in zip(keys, values):
        node = tree
        parts = key.split(".")
        for part in parts[:-1]:
            if part not in node or not isinstance(node[part], dict):
                raise ConfigError([f"sweep.keys: {key!r} is not a config key"], source="sweep point")
            node = node[part]
        if parts[-1] not in node:
            raise ConfigError([f"sweep.keys: {key!r} is not a config key"], source="sweep point")
        node[parts[-1]] = value
    f = float(tree["cycle"]["frequency_Hz"])
    if keep_steps_per_cycle:
        tree["sim"]["timestep_s"] = 1.0 / (f * n_base)
    if cycles is not None:
        tree["sim"]["duration_s"] = cycles / f
        tree["sim"]["record_every"] = n_base
    return parse_config(tree, source="sweep point")


# ---------------------------------------------------------------------------------- scenario


@dataclass
class MsacScenario:
    """An MSAC run (see module docs)."""

    cfg: MsacConfig
    spec: mujoco.MjSpec = field(init=False)

    def __post_init__(self) -> None:
        cfg = self.cfg
        self.params = make_params(cfg)
        self.path = make_path(cfg)
        self.spec = build_msac_spec(self.params)
        scale = cfg.bus.inertia_scale
        if scale != 1.0:
            b = self.spec.body("bus")
            b.inertia = (self.params.bus_inertia_kg_m2 * scale).tolist()
        self.model = self.spec.compile()
        self.planar = planar_model(self.params, inertia_scale=scale)
        self.runner = None
        self.last_summary: dict[str, Any] = {}

    # -------------------------------------------------------------- runner
    def simulation(self):
        """The runner: native rollout / computed torque, a sweep, or nothing (``lumped``)."""
        from magsail_mj.scenarios.msac_runner import MsacRunner, StaticRunner

        cfg = self.cfg
        if cfg.scenario == "lumped":
            self.runner = StaticRunner(self.model, self.path)
        elif cfg.scenario == "sweep":
            self.runner = SweepRunner(self)
        else:
            p = cfg.post
            self.runner = MsacRunner(
                model=self.model, path=self.path, duration_s=cfg.sim.duration_s, method=cfg.drive.method,
                record_every=cfg.sim.record_every, omega_c_dt=cfg.drive.omega_c_dt,
                calibration_cycles=cfg.drive.calibration_cycles, chunk_cycles=cfg.drive.chunk_cycles,
                window_s=p.window_s, omega_sample_hz=p.omega_sample_Hz, lowpass_order=p.lowpass_order,
                lowpass_cutoff_hz=p.lowpass_cutoff_Hz, checkpoint_every_s=cfg.sim.checkpoint_every_s,
                momentum_projection=cfg.drive.momentum_projection)
        return self.runner

    # -------------------------------------------------------------- references
    def references(self) -> dict[str, float]:
        """Analytic summary entries: inertias, Eq. (6)/(7) and the exact model (spec §8)."""
        cfg, P, path = self.cfg, self.planar, self.path
        wi = wing_inertias(P, s_e_m=path.s_e_m, s_c_m=path.s_c_m)
        theta_eq6 = lumped_theta(I_e=2 * wi.e_hinge, I_c=2 * wi.c_hinge, I_sat=P.bus_izz_kg_m2,
                                 phi_a=path.phi_a_rad, phi_b=path.phi_b_rad)
        theta_str = lumped_theta(I_e=2 * wi.e_stretch, I_c=2 * wi.c_stretch, I_sat=P.bus_izz_kg_m2,
                                 phi_a=path.phi_a_rad, phi_b=path.phi_b_rad)
        # Eq. (6) is written for the MSAC loop; the other test paths follow from it: the reversed
        # loop flips the sign (T3), a reciprocal path or mirror-symmetric wings give zero (T2, T4)
        sign = {"msac": 1.0, "reversed": -1.0, "bend_only": 0.0, "extend_only": 0.0}[cfg.cycle.pattern]
        if cfg.wings.layout == "mirror":
            sign = 0.0
        theta_eq6, theta_str = sign * theta_eq6, sign * theta_str
        # the exact model holds for point-symmetric wings; mirror wings give zero by symmetry
        exact = 0.0 if cfg.wings.layout == "mirror" else float(exact_rotation_path(P, path.waypoints).sum())
        T = path.period_s
        # momentum scale: the largest shape angular momentum |N_φ φ̇ + N_s ṡ| along the path
        tt = np.linspace(0.0, T, 2001)
        st = cycle_state(path, tt)
        n_phi, n_s = P.shape_momentum_coefficients(st.phi, st.s)
        L_scale = float(np.max(np.abs(n_phi * st.phi_dot + n_s * st.s_dot)))
        return {
            "bus_mass_kg": cfg.bus.mass_kg,
            "bus_izz_kg_m2": P.bus_izz_kg_m2,
            "wing_mass_kg": P.wing_mass_kg,
            "wing_I_rest_hinge_kg_m2": wi.rest_hinge,
            "wing_I_e_hinge_kg_m2": wi.e_hinge,
            "wing_I_c_hinge_kg_m2": wi.c_hinge,
            "wing_I_rest_centre_kg_m2": wi.rest_centre,
            "wing_I_e_centre_kg_m2": wi.e_centre,
            "wing_I_c_centre_kg_m2": wi.c_centre,
            "wing_I_e_stretch_kg_m2": wi.e_stretch,
            "wing_I_c_stretch_kg_m2": wi.c_stretch,
            "extension_model": cfg.wings.extension_model,
            "cycle_frequency_Hz": cfg.cycle.frequency_Hz,
            "cycle_period_s": T,
            "stroke_rad": path.phi_a_rad - path.phi_b_rad,
            "theta_gamma_eq6_model_rad": theta_eq6,
            "theta_gamma_eq6_stretch_rad": theta_str,
            "omega_gamma_eq7_rad_s": theta_eq6 / T,
            "theta_gamma_exact_rad": exact,
            "omega_gamma_exact_rad_s": exact / T,
            "predicted_rate_lumped_rad_s": theta_eq6 / T,
            "predicted_rate_exact_rad_s": exact / T,
            "angmom_scale_N_m_s": L_scale,
        }

    # -------------------------------------------------------------- outputs
    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Summary (spec §8 and issue keys) and derived series (yaw, increments)."""
        if self.cfg.scenario == "sweep":
            summary, series = self.runner.postprocess(result)
        elif self.cfg.scenario == "lumped":
            summary, series = {**self.references(), "simulated_time_s": 0.0, "wall_time_s": result.wall_time_s}, {}
        else:
            summary, series = multibody_summary(self, result, self.references())
        self.last_summary = summary
        return summary, series

    def plots(self, run_dir: Path, result: RunResult, series: dict[str, np.ndarray]) -> list[Path]:
        from magsail_mj.scenarios.msac_plots import msac_plots, sweep_plot

        if self.cfg.scenario == "lumped":
            return []
        if self.cfg.scenario == "sweep":
            return [sweep_plot(self.cfg, run_dir, {**result.records, **series})]
        return msac_plots(self, run_dir, {**result.records, **series,
                                          "_summary": getattr(self, "last_summary", {})})

    def render_info(self) -> dict[str, Any]:
        r, cfg = self.cfg.render, self.cfg
        reach = cfg.wings.hinge_offset_m + cfg.wings.length_m
        return {
            "title": f"MSAC {cfg.scenario}: {cfg.description}".strip(": ")[:80],
            "overlay": ["yaw_unwrapped_rad", "phase"] if cfg.scenario == "multibody" else [],
            "camera": {"azimuth_deg": r.azimuth_deg, "elevation_deg": r.elevation_deg,
                       "distance_m": r.distance_m or 2.6 * reach},
            "fps": r.fps,
            "max_frames": r.max_frames,
            "extension_exaggeration": r.extension_exaggeration,
        }

    def manifest_extra(self) -> dict[str, Any]:
        cfg = self.cfg
        flat = _flatten(cfg.model_dump(mode="json"))
        table = {}
        for key in list(PAPER_VALUES) + list(PLACEHOLDERS):
            if key not in flat:
                continue
            v = flat[key]
            if key in PAPER_VALUES:
                src = "paper" if v == PAPER_VALUES[key] else f"config (paper: {PAPER_VALUES[key]})"
            else:
                src = "placeholder"
            table[key] = {"value": v, "source": src}
        m = self.model
        return {
            "model_size": {"bodies": int(m.nbody), "dofs": int(m.nv), "actuators": int(m.nu)},
            "parameters": table,
            "solver": {"integrator": cfg.sim.integrator, "timestep_s": cfg.sim.timestep_s,
                       "steps_per_cycle": int(round(1 / (cfg.cycle.frequency_Hz * cfg.sim.timestep_s))),
                       "drive": cfg.drive.method, "omega_c_dt": cfg.drive.omega_c_dt,
                       "servo_omega_dt": cfg.drive.servo_omega_dt,
                       "disableflags": int(m.opt.disableflags)},
        }


def _flatten(tree: dict, prefix: str = "") -> dict[str, Any]:
    out = {}
    for k, v in tree.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def multibody_summary(sc: MsacScenario, result: RunResult, ref: dict[str, float]
                      ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Summary of a multibody run (spec §6, §8): stroboscopic increments, two secular-rate
    estimates, angular-momentum drift, peak actuator loads, tracking error."""
    cfg, rec = sc.cfg, result.records
    T = sc.path.period_s
    out: dict[str, Any] = dict(ref)
    series: dict[str, np.ndarray] = {}
    yaw_rec = unwrapped_yaw(rec["qpos"][:, 3:7]) if rec["qpos"].shape[0] else np.zeros(0)
    series["yaw_unwrapped_rad"] = yaw_rec
    st, sq = rec.get("strobe_t", np.zeros(0)), rec.get("strobe_quat", np.zeros((0, 4)))
    yaw = unwrapped_yaw(sq) if sq.shape[0] else np.zeros(0)
    series["strobe_yaw_unwrapped_rad"] = yaw
    disc = cfg.post.discard_cycles
    cycles = max(0, yaw.size - 1)
    out.update({"cycles_simulated": cycles, "simulated_time_s": result.t_end_s,
                "steps": result.steps, "wall_time_s": result.wall_time_s,
                "wall_time_per_step_s": result.wall_time_s / max(result.steps, 1),
                "timestep_s": cfg.sim.timestep_s, "steps_per_cycle": int(rec["run_steps_per_cycle"]),
                "drive_method": cfg.drive.method, "status": result.status})
    exact = ref["theta_gamma_exact_rad"]
    if cycles > disc:
        inc = cycle_increments(yaw, discard=disc)
        series["strobe_increment_rad"] = inc.increments
        kept_t, kept_y = st[disc:], yaw[disc:]
        slope, _ = secular_rate_fit(kept_t, kept_y)
        one_period = inc.mean / T
        if result.t_end_s >= cfg.post.min_filter_duration_s and "omega_z_filtered_rad_s" in rec:
            filt = filtered_rate(rec["omega_filt_t"], rec["omega_z_filtered_rad_s"], edge_s=cfg.post.edge_discard_s)
            method = (f"butterworth order {cfg.post.lowpass_order}, {cfg.post.lowpass_cutoff_Hz:g} Hz, zero phase, "
                      f"{cfg.post.edge_discard_s:g} s edges")
        else:
            filt, method = one_period, "one-period average (run shorter than min_filter_duration_s)"
        out.update({
            "theta_gamma_mujoco_rad": inc.mean,
            "theta_gamma_mujoco_std_rad": inc.std,
            "theta_gamma_first_cycle_rad": inc.first,
            "rate_slope_rad_s": slope,
            "rate_filtered_mean_rad_s": filt,
            "rate_filtered_method": method,
            "rate_one_period_mean_rad_s": one_period,
            "rate_estimates_rel_diff": abs(slope - filt) / abs(slope) if slope else float("nan"),
            "mujoco_vs_exact_rel_diff": (inc.mean - exact) / abs(exact) if exact else float("nan"),
            "mujoco_vs_eq6_rel_diff": ((inc.mean - ref["theta_gamma_eq6_model_rad"])
                                       / abs(ref["theta_gamma_eq6_model_rad"])
                                       if ref["theta_gamma_eq6_model_rad"] else float("nan")),
            "secular_rate_rad_s": slope,
        })
    else:
        for key in ("theta_gamma_mujoco_rad", "theta_gamma_mujoco_std_rad", "theta_gamma_first_cycle_rad",
                    "rate_slope_rad_s", "rate_filtered_mean_rad_s", "rate_estimates_rel_diff",
                    "mujoco_vs_exact_rel_diff", "secular_rate_rad_s"):
            out[key] = float("nan")
    yaw_end = float(yaw_rec[-1] - yaw_rec[0]) if yaw_rec.size else float("nan")
    out["yaw_unwrapped_final_rad"] = yaw_end
    out["net_rotation_rad"] = yaw_end
    out["angmom_drift_max_N_m_s"] = float(rec["run_angmom_drift_max_N_m_s"])
    out["angmom_drift_z_max_N_m_s"] = float(rec["run_angmom_drift_z_max_N_m_s"])
    out["angular_momentum_drift"] = out["angmom_drift_max_N_m_s"] / ref["angmom_scale_N_m_s"]
    out["hinge_torque_peak_N_m"] = float(rec["run_hinge_torque_peak_N_m"])
    out["slide_force_peak_N"] = float(rec["run_slide_force_peak_N"])
    track = rec["run_tracking_error_max"]
    out["tracking_error_bend_max_rad"] = float(max(track[0], track[2]))
    out["tracking_error_slide_max_m"] = float(max(track[1], track[3]))
    out["replay_settle_change"] = float(rec["run_replay_settle_change"])
    proj = rec["run_momentum_projection_sum"]
    out["momentum_projection_count"] = int(rec["run_momentum_projection_count"])
    out["momentum_projection_max_N_m_s"] = float(rec["run_momentum_projection_max"])
    # the signed drift the projection removed, per simulated second (the rotational part of
    # the free joint's momentum, about the bus centre, body Z = world Z in planar motion)
    out["angmom_drift_rate_unprojected_N_m_s_per_s"] = float(proj[5]) / max(result.t_end_s, 1e-300)
    # exact model along the achieved shape path of one cycle of the last full-rate window
    out["theta_gamma_exact_achieved_rad"] = float("nan")
    N = int(rec["run_steps_per_cycle"])
    if "win_t" in rec and rec["win_t"].size:
        wid = rec["win_id"]
        last = wid == wid.max()
        wt, wq = rec["win_t"][last], rec["win_qpos"][last]
        k0 = np.rint(wt / cfg.sim.timestep_s).astype(np.int64)
        starts = np.flatnonzero(k0 % N == 0)
        if starts.size and starts[0] + N < wt.size and starts[0] >= 0:
            i0 = starts[0]
            from magsail_mj.mjcf.msac import shape_indices

            qa = shape_indices(sc.model)["qpos"]
            seg = wq[i0:i0 + N + 1]
            out["theta_gamma_exact_achieved_rad"] = float(
                exact_rotation_samples(sc.planar, seg[:, qa[0]], seg[:, qa[1]])[-1])
    return out, series


@register_builder("msac")
def build_msac_scenario(cfg: MsacConfig) -> MsacScenario:
    """Scenario object of an MSAC config."""
    return MsacScenario(cfg=cfg)


# ---------------------------------------------------------------------------------- sweeps


@dataclass
class SweepRunner:
    """Runs every point of a ``[sweep]`` (multibody run + references per point).

    ``records`` hold the first point's ``t``/``qpos`` (so the run folder renders) and, per
    point, ``sweep_*`` arrays: the swept values, the per-cycle rotation from Eq. (6), the exact
    model and MuJoCo, the secular rates, the peak hinge torque and slide force, and the
    wall time.
    """

    scenario: MsacScenario
    #: a sweep of whole runs: no checkpoints, so no stop/resume
    checkpoints = False

    def run(self, *, progress: bool = False, checkpoint_path: Any = None, resume: bool = False,
            stop_after_s: float | None = None) -> RunResult:
        import time

        cfg = self.scenario.cfg
        sw = cfg.sweep
        wall0 = time.perf_counter()
        rows: list[dict[str, Any]] = []
        first = None
        steps = 0
        for values in sw.points:
            pc = point_config(cfg, sw.keys, values, cycles=sw.cycles, keep_steps_per_cycle=sw.keep_steps_per_cycle)
            sc = MsacScenario(cfg=pc)
            res = sc.simulation().run(progress=False)
            if res.status != "completed":  # a point that went bad ends the sweep with its status
                if res.status == "interrupted":
                    raise KeyboardInterrupt(res.message)
                if first is None:
                    first = res
                return RunResult(records=first.records, status=res.status,
                                 message=f"sweep point {dict(zip(sw.keys, values))}: {res.message}",
                                 t_end_s=float(res.t_end_s), steps=steps + res.steps,
                                 wall_time_s=time.perf_counter() - wall0)
            summ, _ = sc.postprocess(res)
            steps += res.steps
            if first is None:
                first = res
            rows.append(summ)
        keys = ("theta_gamma_eq6_model_rad", "theta_gamma_eq6_stretch_rad", "theta_gamma_exact_rad",
                "theta_gamma_mujoco_rad", "theta_gamma_mujoco_std_rad", "mujoco_vs_exact_rel_diff",
                "predicted_rate_lumped_rad_s", "predicted_rate_exact_rad_s", "secular_rate_rad_s",
                "hinge_torque_peak_N_m", "slide_force_peak_N", "angular_momentum_drift",
                "cycle_frequency_Hz", "timestep_s", "wall_time_s")
        records = {"t": first.records["t"], "qpos": first.records["qpos"]}
        for k in keys:
            records[f"sweep_{k}"] = np.array([r[k] for r in rows], dtype=float)
        for j, key in enumerate(sw.keys):
            vals = [p[j] for p in sw.points]
            arr = np.array(vals, dtype=float)
            records[f"sweep_value_{j}"] = arr
        return RunResult(records=records, status="completed", message=f"{len(rows)} sweep points",
                         t_end_s=float(first.t_end_s), steps=steps, wall_time_s=time.perf_counter() - wall0)

    def postprocess(self, result: RunResult) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        rec, sw = result.records, self.scenario.cfg.sweep
        summ: dict[str, Any] = {"sweep_base": sw.base, "sweep_keys": list(sw.keys),
                                "sweep_points": [list(p) for p in sw.points], "sweep_cycles": sw.cycles,
                                "wall_time_s": result.wall_time_s}
        for k, v in rec.items():
            if k.startswith("sweep_") and not k.startswith("sweep_value"):
                summ[k] = v.tolist()
        d = np.abs(rec["sweep_mujoco_vs_exact_rel_diff"])
        summ["sweep_mujoco_vs_exact_rel_diff_max"] = float(np.nanmax(d)) if d.size else float("nan")
        return summ, {}
