r"""Config schema of the MSAC concept (``magsail_mj/concepts/msac/configs/*.toml``): pydantic models of ``[bus]``,
``[wings]``, ``[cycle]``, ``[drive]``, ``[post]``, ``[render]`` and ``[sweep]``, the cross-table
checks of a scenario kind (``scenario`` = ``"lumped"``, ``"multibody"`` or ``"sweep"``), the
paper's stated inputs (:data:`PAPER_VALUES`), the cycle of a config (:func:`make_path`) and the
configs of sweep points (:func:`point_config`).

Units SI; config angles in degrees at the edge (``*_deg``).
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, model_validator

from magsail_mj.concepts import register_config
from magsail_mj.config import (
    MAX_STEPS,
    MJ_MINVAL,
    ConfigError,
    ConfigProblem,
    SimConfig,
    StrictModel,
    parse_config,
)
from magsail_mj.concepts.msac.cycle import CyclePath
from magsail_mj.concepts.msac.drive import steps_per_cycle

__all__ = [
    "MsacConfig",
    "BusConfig",
    "WingsConfig",
    "CycleConfig",
    "DriveConfig",
    "ActuatorsConfig",
    "PostConfig",
    "MsacRenderConfig",
    "SweepConfig",
    "PAPER_VALUES",
    "PLACEHOLDERS",
    "make_path",
    "point_config",
    "flatten_keys",
]

Vec3 = tuple[float, float, float]

#: Inputs the paper states; every other physical parameter is a placeholder.
PAPER_VALUES: dict[str, Any] = {
    "wings.length_m": 8.0,
    "wings.width_m": 3.0,
    "wings.count": 2,
    "cycle.frequency_Hz": 1000.0,
    "cycle.bend_a_deg": 10.0,
    "cycle.extension_frac": 0.01,
    "cycle.contraction_frac": 0.0,
    "sim.duration_s": 600.0,
    "actuators.chip_force_N": 200.0,
    "actuators.slide_chips": 4,
    "actuators.hinge_chips": 2,
}
PLACEHOLDERS = (
    "bus.mass_kg",
    "bus.size_m",
    "bus.inertia_scale",
    "wings.thickness_m",
    "wings.areal_density_kg_m2",
    "wings.hinge_offset_m",
    "cycle.bend_b_deg",
    "cycle.phase_fractions",
    "cycle.blend",
    "wings.slide_stiffness_N_m",
    "wings.root_mass_kg",
    "wings.root_inertia_kgm2",
    "actuators.hinge_lever_arm_m",
)


#: largest over smallest body mass or principal inertia of an MSAC model: 1/ε of float64 over 20
MAX_INERTIA_SPREAD = 1.0 / (20.0 * 2.220446049250313e-16)
#: the most ``√(k/m) Δt`` of the wing slide's spring (see ``MsacConfig._check_slide_step``)
MAX_SLIDE_OMEGA_DT = 1.0


class BusConfig(StrictModel):
    """``[bus]``: uniform box (placeholders).

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
    """``[wings]``: two rigid wings, each one rigid slide + one hinge.

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
    root_inertia_kgm2: float = Field(default=1e-6, gt=MJ_MINVAL)


class CycleConfig(StrictModel):
    """``[cycle]``: the four-phase path.

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
    """``[drive]``: ``held_torque`` = native rollout of the settled
    computed-torque cycle's torques, each held over its step, with a once-per-cycle trim and no
    servos (momentum conserved to round-off, :mod:`magsail_mj.concepts.msac.drive`); ``replay`` =
    the same torques plus joint servos, which leak momentum under RK4; ``computed_torque`` =
    Python loop per step. ``momentum_projection``: zero the total momentum every
    ``chunk_cycles`` cycles (see :mod:`magsail_mj.concepts.msac.runner`); unset = on for
    ``replay`` only (:attr:`projection`). The default is ``held_torque``: no projection needed
    (drift 1e-9 N m s per cycle at 5 µs vs 1e-4 for the servo replay); the dm_control environment
    drives the servo ``replay``, whose actions are joint targets."""

    method: Literal["replay", "computed_torque", "held_torque"] = "held_torque"
    omega_c_dt: float = Field(default=0.2, gt=0, le=1.0)
    servo_omega_dt: float = Field(default=0.05, gt=0, le=0.5)
    calibration_cycles: int = Field(default=3, ge=2)
    chunk_cycles: int = Field(default=200, ge=1)
    momentum_projection: bool | None = None

    @property
    def projection(self) -> bool:
        """Whether the runner projects the momentum: ``momentum_projection``, or when unset, on
        for the servo ``replay`` (its leak) and off for the torque drives (which conserve it)."""
        return self.method == "replay" if self.momentum_projection is None else self.momentum_projection


class ActuatorsConfig(StrictModel):
    """``[actuators]``: what the shape-joint actuators of one wing can deliver (the paper's piezo
    drive), to judge the demand of the prescribed motion.

    The paper's simple actuator embeds four multilayer piezo chips (extension only, 200 N peak
    each) in a bar: all four extend it (``slide_chips = 4``), two adjacent ones bend it
    (``hinge_chips = 2``). The bending chips act at ``hinge_lever_arm_m`` from the bar's
    neutral axis (not in the paper: placeholder, half the 3 cm panel thickness). A lever of
    ``amplification`` ``a`` multiplies the stroke by ``a`` and divides the force by ``a`` (the
    paper's amplified actuator: ``a ≈ 50``). ``units`` actuators act in parallel on each joint.
    Capacities: slide ``F_max = units · slide_chips · chip_force_N / a`` [N], hinge
    ``τ_max = units · hinge_chips · chip_force_N · hinge_lever_arm_m / a`` [N m].
    """

    chip_force_N: float = Field(default=200.0, gt=0)
    slide_chips: int = Field(default=4, ge=1)
    hinge_chips: int = Field(default=2, ge=1)
    hinge_lever_arm_m: float = Field(default=0.015, gt=0)
    amplification: float = Field(default=1.0, gt=0)
    units: int = Field(default=1, ge=1)

    @property
    def slide_force_max_N(self) -> float:
        """Force capacity of one wing's slide [N] (class docs)."""
        return self.units * self.slide_chips * self.chip_force_N / self.amplification

    @property
    def hinge_torque_max_Nm(self) -> float:
        """Torque capacity of one wing's hinge [N m] (class docs)."""
        return self.units * self.hinge_chips * self.chip_force_N * self.hinge_lever_arm_m / self.amplification


class PostConfig(StrictModel):
    """``[post]``: discarded start-up cycles, low-pass filter, edge discard, windows."""

    discard_cycles: int = Field(default=1, ge=0)
    lowpass_order: int = Field(default=4, ge=1, le=10)
    lowpass_cutoff_Hz: float = Field(default=10.0, gt=0)
    edge_discard_s: float = Field(default=1.0, ge=0)
    min_filter_duration_s: float = Field(default=5.0, gt=0)
    window_s: float = Field(default=0.02, gt=0)
    omega_sample_Hz: float = Field(default=20000.0, gt=0)


class MsacRenderConfig(StrictModel):
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

    ``base`` names the scenario id the sweep starts from (``magsail_mj/concepts/msac/configs/<base>.toml``; a test
    checks the file's other tables equal it). ``cycles`` sets each point's duration;
    ``keep_steps_per_cycle`` rescales ``sim.timestep_s`` with the cycle period so that every
    point has the base's steps per cycle (frequency sweeps, the time-scaling test).
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


@register_config("msac")
class MsacConfig(StrictModel):
    """An MSAC scenario config (``magsail_mj/concepts/msac/configs/*.toml``)."""

    concept: Literal["msac"]
    scenario: Literal["lumped", "multibody", "sweep"]
    description: str = ""
    sim: SimConfig
    bus: BusConfig = BusConfig()
    wings: WingsConfig = WingsConfig()
    cycle: CycleConfig = CycleConfig()
    drive: DriveConfig = DriveConfig()
    actuators: ActuatorsConfig = ActuatorsConfig()
    post: PostConfig = PostConfig()
    render: MsacRenderConfig = MsacRenderConfig()
    sweep: SweepConfig | None = None

    @model_validator(mode="after")
    def _consistent(self) -> MsacConfig:
        if (self.scenario == "sweep") != (self.sweep is not None):
            raise ConfigProblem(
                "scenario", "a [sweep] table goes with scenario = 'sweep' and only with it", others=("sweep",)
            )
        if self.scenario != "lumped":
            self._check_steps_per_cycle()
        if self.sweep is not None:
            flat = flatten_keys(self.model_dump(mode="json", exclude={"sweep"}))
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
                problems += [
                    f"sweep.points[{i}]: {line} (from sweep.keys = {sw.keys}, values {values}, "
                    f"sweep.cycles = {sw.cycles})"
                    for line in err.problems
                ]
        if problems:
            raise ValueError("; ".join(problems))

    def _check_steps_per_cycle(self) -> None:
        """The cycle period 1/f must be a whole number (>= 4) of time steps, fewer than 2⁶³."""
        ratio = (1.0 / self.cycle.frequency_Hz) / self.sim.timestep_s
        if not ratio < MAX_STEPS:
            raise ConfigProblem(
                "sim.timestep_s",
                f"the cycle period 1/cycle.frequency_Hz is {ratio:.3g} time steps, "
                f"more than a 64-bit step counter holds, got {self.sim.timestep_s!r}",
                others=("cycle.frequency_Hz",),
            )
        try:
            steps_per_cycle(make_path(self), self.sim.timestep_s)
        except ValueError as err:
            raise ConfigProblem(
                "sim.timestep_s", str(err).removeprefix("timestep_s: "), others=("cycle.frequency_Hz",)
            ) from None

    @model_validator(mode="after")
    def _numbers(self) -> MsacConfig:
        """The bodies MuJoCo receives (bus box, wing plates, hinge bodies) need masses and
        principal inertias above mjMINVAL and finite, and the joint servo gains J ω_s² finite."""
        b, w = self.bus, self.wings
        bus_keys = ("bus.size_m", "bus.inertia_scale")
        a, bb, c = b.size_m
        for name, (p, q) in zip("xyz", ((bb, c), (a, c), (a, bb))):
            _positive_product(
                "bus.mass_kg",
                b.mass_kg / 12.0 * b.inertia_scale,
                p * p + q * q,
                what=f"bus inertia I_{name}",
                others=bus_keys,
            )
        wing_keys = ("wings.length_m", "wings.width_m", "wings.thickness_m")
        m = _positive_product(
            "wings.areal_density_kg_m2",
            w.areal_density_kg_m2,
            w.length_m * w.width_m,
            what="wing mass σ ℓ w",
            others=wing_keys,
        )
        l, wd, t = w.length_m, w.width_m, w.thickness_m
        for name, (p, q) in zip("xyz", ((t, wd), (l, wd), (l, t))):
            _positive_product(
                "wings.areal_density_kg_m2", m / 12.0, p * p + q * q, what=f"wing inertia I_{name}", others=wing_keys
            )
        omega = self.drive.servo_omega_dt / self.sim.timestep_s
        hinge = m * (l * l + t * t) / 12.0 + m * (l / 2) * (l / 2)
        _positive_product(
            "drive.servo_omega_dt",
            max(hinge, m, 1.0),
            2.0 * omega * omega,
            what="servo gain J ω_s²",
            others=("sim.timestep_s", "wings.areal_density_kg_m2", *wing_keys),
        )
        self._check_spread(m)
        self._check_slide_step(m)
        return self

    def _check_spread(self, wing_mass_kg: float) -> None:
        """Largest over smallest body mass, and over smallest principal inertia, at most
        :data:`MAX_INERTIA_SPREAD`: a body lighter than the rounding of the heaviest one's (relative
        ``ε = 2.2e-16``) is lost in MuJoCo's joint-space inertia factorisation (the held-torque
        calibration then fails on a singular matrix). The largest inertia counts the wing about
        the bus centre, ``m (r0 + ℓ)²``; masses and inertias as in :meth:`_numbers`."""
        b, w = self.bus, self.wings
        a, bb, c = b.size_m
        scale = b.mass_kg / 12.0 * b.inertia_scale
        l, wd, t, m = w.length_m, w.width_m, w.thickness_m, wing_mass_kg
        bus = ("bus.mass_kg", "bus.size_m", "bus.inertia_scale")
        wing = ("wings.length_m", "wings.width_m", "wings.thickness_m", "wings.areal_density_kg_m2")
        inertias = [(scale * (p * p + q * q), bus) for p, q in ((bb, c), (a, c), (a, bb))]
        inertias += [(m / 12.0 * (p * p + q * q), wing) for p, q in ((t, wd), (l, wd), (l, t))]
        inertias += [(w.root_inertia_kgm2, ("wings.root_inertia_kgm2",))]
        reach = w.hinge_offset_m + l
        about_bus = m * reach * reach  # inf, not an OverflowError, at extreme lengths
        masses = [(b.mass_kg, ("bus.mass_kg",)), (m, wing), (w.root_mass_kg, ("wings.root_mass_kg",))]
        for what, values, largest in (
            ("body mass", masses, max(masses)),
            ("principal inertia", inertias, max([*inertias, (about_bus, ("wings.hinge_offset_m", *wing))])),
        ):
            smallest = min(values)
            spread = largest[0] / smallest[0]
            if not spread <= MAX_INERTIA_SPREAD:
                keys = tuple(dict.fromkeys((*largest[1], *smallest[1])))
                raise ConfigProblem(
                    keys[0],
                    f"makes the largest {what} {largest[0]:.3g} and the smallest {smallest[0]:.3g}, a ratio of "
                    f"{spread:.3g} above {MAX_INERTIA_SPREAD:.3g}: the smaller body is lost in the rounding of "
                    "the joint-space inertia",
                    others=keys[1:],
                )

    def _check_slide_step(self, wing_mass_kg: float) -> None:
        """The wing slide's spring ``k`` resolved by the time step: ``√(k/m) Δt ≤``
        :data:`MAX_SLIDE_OMEGA_DT` (the explicit integrators' stability limit of an undamped
        oscillator is 2 for semi-implicit Euler and 2.8 for RK4; 1 keeps it accurate too)."""
        omega_dt = math.sqrt(self.wings.slide_stiffness_N_m / wing_mass_kg) * self.sim.timestep_s
        if not omega_dt <= MAX_SLIDE_OMEGA_DT:
            raise ConfigProblem(
                "wings.slide_stiffness_N_m",
                f"gives the wing slide ω Δt = √(k/m) Δt = {omega_dt:.3g}, above {MAX_SLIDE_OMEGA_DT:g} "
                f"(the step cannot resolve the slide's oscillation), got {self.wings.slide_stiffness_N_m!r}",
                others=("sim.timestep_s", "wings.areal_density_kg_m2", "wings.length_m", "wings.width_m"),
            )


def _positive_product(key: str, a: float, b: float, *, what: str, others: tuple[str, ...]) -> float:
    """``a · b``: a :class:`ConfigProblem` on ``key`` when it is not finite or not above mjMINVAL."""
    value = a * b
    if not math.isfinite(value):
        raise ConfigProblem(key, f"makes the {what} overflow float64", others=others)
    if not value > MJ_MINVAL:
        raise ConfigProblem(
            key, f"makes the {what} {value:.6g}, which must be > {MJ_MINVAL:g} (mjMINVAL)", others=others
        )
    return value


def make_path(cfg: MsacConfig) -> CyclePath:
    """The cycle of a config: ``φa``, ``φb`` from degrees, ``s`` from fractions of ℓ."""
    c, l = cfg.cycle, cfg.wings.length_m
    return CyclePath(
        phi_a_rad=math.radians(c.bend_a_deg),
        phi_b_rad=math.radians(c.bend_b_deg),
        s_e_m=c.extension_frac * l,
        s_c_m=-c.contraction_frac * l,
        period_s=1.0 / c.frequency_Hz,
        fractions=tuple(c.phase_fractions),
        blend=c.blend,
        pattern=c.pattern,
    )


def point_config(
    cfg: MsacConfig, keys: list[str], values: list[Any], *, cycles: int | None = None, keep_steps_per_cycle: bool = True
) -> MsacConfig:
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


def flatten_keys(tree: dict, prefix: str = "") -> dict[str, Any]:
    """``{dotted.key: value}`` of a nested table (``{"a": {"b": 1}}`` → ``{"a.b": 1}``)."""
    out = {}
    for k, v in tree.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten_keys(v, key + "."))
        else:
            out[key] = v
    return out
