r"""MjSpec builder of the rigid reflector plate (Robb et al. 2020, Table 1).

One body ``plate`` on a ``freejoint`` (position irrelevant; torques only), gravity off, the
constraint pipeline off (:func:`magsail_mj.mjcf.common.free_space_spec`), explicit inertial at
the body origin = centre of mass. Structure frame: ``x``, ``y`` in the plate, ``z`` normal.

Mass and inertia (paper Eq. 7, square plate of side ``d``, areal density ``σ``, ``m = σ d²``):

.. math:: \mathbf I = \mathrm{diag}\big(\tfrac1{12} m (d^2 + t^2),\ \tfrac1{12} m (d^2 + t^2),\ \tfrac16 m d^2\big).

The flat-plate tensor (``t = 0``) sits exactly on the triangle-inequality limit
``I₁ + I₂ = I₃``, which MuJoCo may reject after rounding; the in-plane moments therefore carry a
thickness ``t`` (default ``t = h``, the lattice depth: relative change
``t²/d² = 10⁻⁴`` for 1 m on 100 m). :func:`plate_mass_properties` returns the values used.

Visual geoms (massless, no contacts): a thin two-coloured plate (front face ``+z`` silver,
back face dark), a simplified coil drawing (every k-th column of the y-coil (orange) and of the
x-coil (cyan), the in-plane loop outline (magenta); drawing all 20 000 segments would exceed the
scene budget), the grey line along body ``x`` (dark grey) and the normal (blue).

Display markers: massless-looking bodies on ``ball`` joints at the world origin, each with an
arrow along its local ``+z`` (``kind = "arrow"``) or a line through the origin along its local
``x`` (``kind = "line"``). They feel no force and keep zero velocity during the run; their
``qpos`` quaternions are filled in from the recorded directions when the run is post-processed,
so the video shows them (the renderer replays ``qpos`` only). A directional light rides on the
marker named ``mk_sun`` when present.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from magsail_mj.checks import require_positive
from magsail_mj.mjcf.common import INTEGRATORS, add_marker_body, add_sun_light, free_space_spec, set_view

__all__ = [
    "PlateModelParams",
    "MarkerSpec",
    "plate_mass_properties",
    "build_plate_spec",
    "plate_indices",
    "PlateIndices",
]

_FRONT_RGBA = (0.85, 0.87, 0.92, 1.0)
_BACK_RGBA = (0.25, 0.27, 0.32, 1.0)
_YCOIL_RGBA = (1.0, 0.55, 0.1, 1.0)
_XCOIL_RGBA = (0.1, 0.8, 0.9, 1.0)
_ZLOOP_RGBA = (0.55, 0.35, 1.0, 1.0)
_GREY_LINE_RGBA = (0.15, 0.15, 0.15, 1.0)
_NORMAL_RGBA = (0.1, 0.3, 1.0, 1.0)


@dataclass(frozen=True)
class MarkerSpec:
    """A display marker: ``name`` (body ``name``, joint ``name_ball``), colour, ``kind``
    (``"arrow"`` along local +z, or ``"line"`` along local x through the origin) and length
    relative to the plate side."""

    name: str
    rgba: tuple[float, float, float, float]
    kind: str = "arrow"
    length_rel: float = 0.85


def plate_mass_properties(*, side_m: float, areal_density_kg_m2: float, thickness_m: float) -> tuple[float, np.ndarray]:
    """``(m, (I₁, I₂, I₃))``: mass [kg] and principal inertia [kg m²] of the module docstring."""
    for name, v in (("side_m", side_m), ("areal_density_kg_m2", areal_density_kg_m2)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name}: must be > 0, got {v!r}")
    if not (math.isfinite(thickness_m) and thickness_m > 0):
        raise ValueError(
            f"inertia_thickness_m: must be > 0 (the flat plate sits on the triangle-inequality "
            f"limit), got {thickness_m!r}"
        )
    m = areal_density_kg_m2 * side_m**2
    I12 = m * (side_m**2 + thickness_m**2) / 12.0
    return m, np.array([I12, I12, m * side_m**2 / 6.0])


@dataclass(frozen=True)
class PlateModelParams:
    """Inputs of :func:`build_plate_spec` (SI units; defaults: baseline).

    Attributes:
      side_m: plate side d; cell_m: cell edge L; depth_m: lattice depth h (A1: = L).
      areal_density_kg_m2: σ (0.1 baseline, 0.01 second reflector case).
      inertia_thickness_m: t in the in-plane moments (default h).
      coil_pitch_cells: column pitch p of the drawn coil; zloop_side_m: drawn in-plane loop side
        (``None``: not drawn); coil_columns_drawn: columns of each coil drawn.
      timestep_s, integrator: MuJoCo options.
      markers: display markers.
      name: model name.
    """

    side_m: float = 100.0
    cell_m: float = 1.0
    depth_m: float | None = None
    areal_density_kg_m2: float = 0.1
    inertia_thickness_m: float | None = None
    coil_pitch_cells: int = 2
    zloop_side_m: float | None = None
    coil_columns_drawn: int = 10
    timestep_s: float = 0.1
    integrator: str = "RK4"
    solver_tolerance: float | None = None
    markers: tuple[MarkerSpec, ...] = field(default_factory=tuple)
    name: str = "reflector_plate"

    def __post_init__(self) -> None:
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"integrator: must be one of {sorted(INTEGRATORS)}, got {self.integrator!r}")
        require_positive(self, ("side_m", "cell_m", "timestep_s"))

    @property
    def depth(self) -> float:
        return self.cell_m if self.depth_m is None else float(self.depth_m)

    @property
    def thickness(self) -> float:
        return self.depth if self.inertia_thickness_m is None else float(self.inertia_thickness_m)

    def mass_properties(self) -> tuple[float, np.ndarray]:
        return plate_mass_properties(
            side_m=self.side_m, areal_density_kg_m2=self.areal_density_kg_m2, thickness_m=self.thickness
        )


def build_plate_spec(params: PlateModelParams | None = None) -> mujoco.MjSpec:
    """Return the ``MjSpec`` of the reflector plate (see the module docstring)."""
    p = params or PlateModelParams()
    spec = free_space_spec(
        name=p.name, timestep_s=p.timestep_s, integrator=p.integrator, solver_tolerance=p.solver_tolerance
    )
    d = p.side_m
    set_view(spec, extent=2.0 * d, headlight_diffuse=[0.6, 0.6, 0.6], headlight_ambient=[0.3, 0.3, 0.3])
    nogeo = dict(contype=0, conaffinity=0, mass=0)
    box, cap = mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CAPSULE

    mass, inertia = p.mass_properties()
    plate = spec.worldbody.add_body(name="plate")
    plate.add_freejoint(name="plate_free")
    plate.explicitinertial = True
    plate.mass = float(mass)
    plate.ipos = [0.0, 0.0, 0.0]
    plate.inertia = inertia.tolist()

    t = 0.004 * d  # drawn thickness of each face
    plate.add_geom(
        name="plate_front", type=box, size=[d / 2, d / 2, t / 2], pos=[0, 0, t / 2], rgba=list(_FRONT_RGBA), **nogeo
    )
    plate.add_geom(
        name="plate_back", type=box, size=[d / 2, d / 2, t / 2], pos=[0, 0, -t / 2], rgba=list(_BACK_RGBA), **nogeo
    )
    # simplified coils: every k-th column of each coil, as strips just off the front face
    L = p.cell_m
    n_col = max(1, round(d / L) // max(1, p.coil_pitch_cells))
    k = max(1, n_col // max(1, p.coil_columns_drawn))
    w = max(L / 2, 0.004 * d)
    for j in range(0, n_col, k):
        xc = -d / 2 + j * p.coil_pitch_cells * L + L / 2
        plate.add_geom(
            name=f"ycoil_col{j}",
            type=box,
            size=[w / 2, d / 2, t / 4],
            pos=[xc, 0, 1.3 * t],
            rgba=list(_YCOIL_RGBA),
            group=1,
            **nogeo,
        )
        plate.add_geom(
            name=f"xcoil_col{j}",
            type=box,
            size=[d / 2, w / 2, t / 4],
            pos=[0, xc, 1.6 * t],
            rgba=list(_XCOIL_RGBA),
            group=1,
            **nogeo,
        )
    if p.zloop_side_m is not None:
        s = p.zloop_side_m / 2
        corners = [(-s, -s), (s, -s), (s, s), (-s, s), (-s, -s)]
        for i in range(4):
            (x0, y0), (x1, y1) = corners[i], corners[i + 1]
            plate.add_geom(
                name=f"zloop_{i}",
                type=cap,
                fromto=[x0, y0, 2 * t, x1, y1, 2 * t],
                size=[w, 0, 0],
                rgba=list(_ZLOOP_RGBA),
                group=1,
                **nogeo,
            )
    plate.add_geom(
        name="grey_line",
        type=cap,
        fromto=[-0.6 * d, 0, 2.2 * t, 0.6 * d, 0, 2.2 * t],
        size=[0.008 * d, 0, 0],
        rgba=list(_GREY_LINE_RGBA),
        group=2,
        **nogeo,
    )
    plate.add_geom(
        name="normal",
        type=cap,
        fromto=[0, 0, 0, 0, 0, 0.35 * d],
        size=[0.008 * d, 0, 0],
        rgba=list(_NORMAL_RGBA),
        group=2,
        **nogeo,
    )

    for mk in p.markers:
        body = add_marker_body(spec.worldbody, mk.name)
        Lm = mk.length_rel * d
        if mk.kind == "arrow":
            body.add_geom(
                name=f"{mk.name}_shaft",
                type=cap,
                fromto=[0, 0, 0.15 * d, 0, 0, Lm],
                size=[0.008 * d, 0, 0],
                rgba=list(mk.rgba),
                group=2,
                **nogeo,
            )
            body.add_geom(
                name=f"{mk.name}_head",
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                pos=[0, 0, Lm],
                size=[0.03 * d, 0, 0],
                rgba=list(mk.rgba),
                group=2,
                **nogeo,
            )
        elif mk.kind == "line":
            body.add_geom(
                name=f"{mk.name}_line",
                type=cap,
                fromto=[-Lm, 0, 0, Lm, 0, 0],
                size=[0.005 * d, 0, 0],
                rgba=list(mk.rgba),
                group=2,
                **nogeo,
            )
        else:
            raise ValueError(f"markers[{mk.name}].kind: must be 'arrow' or 'line', got {mk.kind!r}")
        if mk.name == "mk_sun":
            add_sun_light(body, height=3 * d, diffuse=[0.7, 0.7, 0.6])
    return spec


@dataclass(frozen=True)
class PlateIndices:
    """Address book of a compiled plate model."""

    plate: int
    q_quat: slice  # plate quaternion qpos[3:7] (world ← body, scalar first)
    v_ang: slice  # plate body rate qvel[3:6] (body components)
    marker_qpos: dict[str, int]


def plate_indices(model: mujoco.MjModel) -> PlateIndices:
    """Indices of the plate and its markers in a model built by :func:`build_plate_spec`."""
    b = model.body("plate").id
    ja = model.body_jntadr[b]
    qa, va = int(model.jnt_qposadr[ja]), int(model.jnt_dofadr[ja])
    markers = {}
    for j in range(model.njnt):
        name = model.joint(j).name
        if name.endswith("_ball"):
            markers[name[:-5]] = int(model.jnt_qposadr[j])
    return PlateIndices(plate=b, q_quat=slice(qa + 3, qa + 7), v_ang=slice(va + 3, va + 6), marker_qpos=markers)
