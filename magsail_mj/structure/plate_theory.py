r"""Kirchhoff plate references for the truss plates: free square and circular plates, the
homogenised bending rigidities of the two-layer lattices, and the cantilever that maps a
calibrated ``EI`` to a plate rigidity (NumPy/SciPy and scikit-fem).

Plate. A thin plate in the x–y plane with deflection ``w(x, y)`` [m], areal density ``ρ_A``
[kg/m²] and the bending rigidities of a plate with square symmetry (``D22 = D11``; isotropic when
``D66 = (D11 − D12) / 2``) [N m] stores

    U = ½ ∫ [D11 (w_xx² + w_yy²) + 2 D12 w_xx w_yy + 4 D66 w_xy²] dA,

and its free vibrations ``w e^{iωt}`` make ``∫ ρ_A ω² w v dA`` equal the bilinear form of ``U`` for
every test field ``v``; a free edge is the natural boundary condition, nothing is imposed. The
isotropic plate of rigidity ``D`` and Poisson ratio ``ν`` has ``D11 = D``, ``D12 = ν D``,
``D66 = (1 − ν) D / 2``. Frequencies are quoted as the parameter ``λ² = ω L² √(ρ_A / D11)``
(``L`` the side of a square, the radius of a disc): ``ω = λ² √(D11 / (ρ_A L⁴))``.

Finite elements (:func:`free_plate_modes`). The form above on a triangle mesh with the Argyris
element (quintic, ``C¹``; the default) or the Morley element (quadratic, non-conforming), the
generalised eigenproblem ``K φ = ω² M φ`` solved by shift-invert Lanczos below the three rigid
motions (``w = 1, x, y``), which are checked and dropped. On the unit square (ν = 0.3) the
Argyris element on 8 × 8 × 2 triangles gives λ² = 13.468, 19.596, 24.270, 34.801, 34.801: the
values tabulated by Leissa (Vibration of Plates, NASA SP-160, 1969, the completely free square
plate, ν = 0.3: 13.468, 19.596, 24.270, 34.801, 34.801), which serve only as a cross-check.

Disc (:func:`free_disc_lambda2`). The isotropic free circular plate of radius ``R``: with
``w = [A J_n(λ r/R) + C I_n(λ r/R)] cos nθ`` the free-edge conditions at ``r = R`` (radial moment
``M_r = −D [w_rr + ν (w_r / r + w_θθ / r²)]`` and Kirchhoff shear
``V_r = −D [∂_r ∇²w + (1 − ν) r⁻¹ ∂_r (r⁻¹ w_θθ)]`` both zero) read, at ``R = 1``,

    M:  A [−λ² J_n + (1 − ν)(n² J_n − λ J_n')] + C [λ² I_n + (1 − ν)(n² I_n − λ I_n')] = 0,
    V:  A [−λ³ J_n' − (1 − ν) n² (λ J_n' − J_n)] + C [λ³ I_n' − (1 − ν) n² (λ I_n' − I_n)] = 0,

(Bessel's equation eliminates the second derivatives); the roots of the 2 × 2 determinant (the
``I_n`` column divided by ``I_n(λ) > 0``) are bracketed on a grid and refined by Brent's method.
``n`` is the number of nodal diameters; ``n = 0`` and ``n = 1`` also have the rigid roots
``λ = 0``, not returned. At ν = 0.3 the lowest are λ² = 5.358 (n = 2), 9.003 (n = 0, one nodal
circle), 12.439 (n = 3), 20.475 (n = 1, one nodal circle), 21.835 (n = 4); at ν = 0.33 5.262,
9.069, 12.244, 20.513, within 0.2 % of the values Leissa (op. cit.) tabulates for ν = 0.33
(5.253, 9.084, 12.23, 20.52), a cross-check only.

Lattice rigidities (:func:`two_layer_rigidity`). Two equal strut layers at ``z = ±h/2``, each a
membrane of stiffness ``A_ijkl = Σ_f ρ_f EA L_f n_i n_j n_k n_l`` [N/m] (family ``f`` of struts of
length ``L_f``, direction ``n`` and ``ρ_f`` struts per unit area, every strut strained by the
affine field ``ε``), bend as ``D = A h² / 2`` under the Kirchhoff field ``ε = −z κ``, ``κ`` the
curvatures. The web struts are unstrained by that field (their end displacements along the strut
cancel), so they do not enter ``D``; they carry the transverse shear, which the Kirchhoff plate
neglects. The cubic lattice of cube edge ``a`` (``h = a``): chords ``a`` along x and y, one per
cell ``a²`` each, and face diagonals ``a√2`` at ±45°, half a cell's worth each (``"parity"``,
alternating) or one each (``"X"``)::

    parity:  D11 = EA a (1 + √2/4) / 2,  D12 = D66 = √2 EA a / 8   (ν = D12/D11 = 0.2612,
             2 D66 / (D11 − D12) = 0.7071: its twist is 0.71 of an isotropic plate's),
    X:       D11 = EA a (1 + √2/2) / 2,  D12 = D66 = √2 EA a / 4   (ν = 0.4142, ratio 1.414).

The octet plate has only the ±45° chords (``a√2``, ``1 / (2a²)`` each): ``D11 = D12 = D66``, so
the saddle ``w = x² − y²`` (the twist about its chords) stores nothing; the offset grid has only
x and y chords: ``D12 = D66 = 0``, the twist ``w = x y`` stores nothing. Their rim and corner
bracing alone resist those motions, which no Kirchhoff plate of theirs describes.

Cantilever (:func:`cantilever_rigidity_factor`). The calibration of
:mod:`magsail_mj.structure.generators.calibration` clamps a square plate of side ``d`` along one
edge, loads the opposite edge with ``P`` and sets ``EI = P d³ / (3 δ)`` from the mean tip
deflection ``δ``. The same test on the Kirchhoff plate (Argyris element; clamped: ``w = ∂w/∂x = 0``
along ``x = −d/2``, uniform line load ``P/d`` along ``x = +d/2``) gives the factor
``c = EI / (D11 d)``: 1 for ``D12 = 0`` (cylindrical bending), between ``1 − ν²`` (anticlastic
bending free) and 1 otherwise (the clamp holds the anticlastic curvature near the root). A lattice
calibrated to ``EI`` is therefore the plate of ``D11 = EI / (c d)`` as its cubes shrink, not
exactly ``EI / d``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq
from scipy.sparse.linalg import eigsh, spsolve
from scipy.spatial import cKDTree
from scipy.special import iv, ive, ivp, jv, jvp
from skfem import Basis, BilinearForm, ElementTriArgyris, ElementTriMorley, FacetBasis, LinearForm, MeshTri, condense

from magsail_mj.structure.generators.common import check_positive

__all__ = [
    "PlateRigidity",
    "KirchhoffModes",
    "cantilever_rigidity_factor",
    "cubic_lattice_rigidity",
    "disc_mesh",
    "free_disc_lambda2",
    "free_plate_modes",
    "frequency_parameter",
    "octet_rigidity",
    "offset_grid_rigidity",
    "square_mesh",
    "square_symmetry_class",
    "two_layer_rigidity",
]

#: Relative tolerance of the square-symmetry checks of a membrane stiffness (``A22 = A11``, no
#: shear–extension coupling).
SYMMETRY_RTOL = 1e-9
#: A mode counts as rigid when ``ω² < RIGID_REL · D11 / (ρ_A L⁴)`` (``L`` the mesh's extent).
RIGID_REL = 1e-6
#: Parity product above which a mode of a square-symmetric shape is of a one-dimensional class.
_PARITY_MIN = 0.5
_ELEMENTS = {"argyris": ElementTriArgyris, "morley": ElementTriMorley}


@dataclass(frozen=True)
class PlateRigidity:
    """Bending rigidities of a plate with square symmetry (``D22 = D11``) [N m], the energy of the
    module docstring."""

    D11_Nm: float
    D12_Nm: float
    D66_Nm: float

    def __post_init__(self) -> None:
        check_positive("D11_Nm", self.D11_Nm)
        if not (math.isfinite(self.D12_Nm) and abs(self.D12_Nm) <= self.D11_Nm * (1 + SYMMETRY_RTOL)):
            raise ValueError(f"D12_Nm: must satisfy |D12| <= D11 = {self.D11_Nm!r}, got {self.D12_Nm!r}")
        if not (math.isfinite(self.D66_Nm) and self.D66_Nm >= 0):
            raise ValueError(f"D66_Nm: must be finite and >= 0, got {self.D66_Nm!r}")

    @classmethod
    def isotropic(cls, D_Nm: float, nu: float) -> PlateRigidity:
        """The isotropic plate: ``D11 = D``, ``D12 = ν D``, ``D66 = (1 − ν) D / 2``."""
        if not -1.0 < nu < 1.0:
            raise ValueError(f"nu: must lie in (-1, 1), got {nu!r}")
        D = check_positive("D_Nm", D_Nm)
        return cls(D11_Nm=D, D12_Nm=nu * D, D66_Nm=(1.0 - nu) * D / 2.0)

    @property
    def poisson_ratio(self) -> float:
        """``ν = D12 / D11``: the ratio of the curvatures of a plate bent by one moment alone."""
        return self.D12_Nm / self.D11_Nm

    @property
    def twist_ratio(self) -> float:
        """``2 D66 / (D11 − D12)``: the twisting rigidity over the isotropic plate's of the same
        ``D11`` and ``ν`` (1 isotropic; ``inf`` when ``D12 = D11``)."""
        gap = self.D11_Nm - self.D12_Nm
        return math.inf if gap <= 0 else 2.0 * self.D66_Nm / gap


def two_layer_rigidity(*, EA_N: float, depth_m: float, families: Iterable[tuple[float, float, float]]) -> PlateRigidity:
    """Homogenised rigidities ``D = A h² / 2`` of two equal strut layers ``depth_m`` apart, each
    made of the strut ``families`` ``(length_m, angle_rad, per_area_1_m2)`` (module docstring).

    Raises ``ValueError`` when the layer is not square-symmetric (``A22 ≠ A11`` or a shear–extension
    coupling ``A16``, ``A26``)."""
    EA, h = check_positive("EA_N", EA_N), check_positive("depth_m", depth_m)
    table = np.asarray(list(families), dtype=float).reshape(-1, 3)
    if table.size == 0 or np.any(table[:, 0] <= 0) or np.any(table[:, 2] < 0):
        raise ValueError(f"families: need rows (length_m > 0, angle_rad, per_area_1_m2 >= 0), got {table.tolist()!r}")
    length, angle, density = table.T
    c, s = np.cos(angle), np.sin(angle)
    weight = EA * length * density
    A11, A22, A12 = weight @ c**4, weight @ s**4, weight @ (c**2 * s**2)
    A16, A26 = weight @ (c**3 * s), weight @ (c * s**3)
    scale = max(A11, A22)
    if abs(A22 - A11) > SYMMETRY_RTOL * scale or max(abs(A16), abs(A26)) > SYMMETRY_RTOL * scale:
        raise ValueError(
            f"families: the layer is not square-symmetric (A11 = {A11:.6g}, A22 = {A22:.6g}, "
            f"A16 = {A16:.3g}, A26 = {A26:.3g} N/m)"
        )
    factor = h**2 / 2.0
    return PlateRigidity(D11_Nm=A11 * factor, D12_Nm=A12 * factor, D66_Nm=A12 * factor)


def cubic_lattice_rigidity(
    *, EA_N: float, cube_edge_m: float, diagonals: Literal["parity", "X"] = "parity"
) -> PlateRigidity:
    """The two-layer cubic lattice's rigidities (module docstring; every strut ``EA_N``)."""
    a = check_positive("cube_edge_m", cube_edge_m)
    if diagonals not in ("parity", "X"):
        raise ValueError(f"diagonals: must be 'parity' or 'X', got {diagonals!r}")
    per_cell = 1.0 / a**2
    diagonal = (0.5 if diagonals == "parity" else 1.0) * per_cell
    d = a * math.sqrt(2.0)
    families = [(a, 0.0, per_cell), (a, math.pi / 2, per_cell), (d, math.pi / 4, diagonal), (d, -math.pi / 4, diagonal)]
    return two_layer_rigidity(EA_N=EA_N, depth_m=a, families=families)


def octet_rigidity(*, EA_N: float, cube_edge_m: float) -> PlateRigidity:
    """The octet plate's rigidities (chords ``a√2`` at ±45°, ``1 / (2a²)`` per area each, depth
    ``a``): ``D11 = D12 = D66 = √2 EA a / 8``, ``ν = 1``."""
    a = check_positive("cube_edge_m", cube_edge_m)
    d, density = a * math.sqrt(2.0), 0.5 / a**2
    return two_layer_rigidity(EA_N=EA_N, depth_m=a, families=[(d, math.pi / 4, density), (d, -math.pi / 4, density)])


def offset_grid_rigidity(*, EA_N: float, pitch_m: float, depth_m: float) -> PlateRigidity:
    """The offset grid's rigidities (chords ``a`` along x and y, ``1 / a²`` per area each):
    ``D11 = EA h² / (2a)``, ``D12 = D66 = 0``."""
    a = check_positive("pitch_m", pitch_m)
    families = [(a, 0.0, 1.0 / a**2), (a, math.pi / 2, 1.0 / a**2)]
    return two_layer_rigidity(EA_N=EA_N, depth_m=depth_m, families=families)


def frequency_parameter(omega_rad_s, *, length_m: float, D_Nm: float, areal_density_kg_m2: float) -> np.ndarray:
    """``λ² = ω L² √(ρ_A / D)`` of circular frequencies ``omega_rad_s`` [rad/s]."""
    L, D = check_positive("length_m", length_m), check_positive("D_Nm", D_Nm)
    rho = check_positive("areal_density_kg_m2", areal_density_kg_m2)
    return np.asarray(omega_rad_s, dtype=float) * L**2 * math.sqrt(rho / D)


def square_mesh(*, side_m: float, divisions: int) -> MeshTri:
    """The square ``[−d/2, d/2]²`` cut into ``divisions²`` squares of two triangles each."""
    if isinstance(divisions, bool) or int(divisions) != divisions or divisions < 1:
        raise ValueError(f"divisions: must be an integer >= 1, got {divisions!r}")
    half = check_positive("side_m", side_m) / 2.0
    ticks = np.linspace(-half, half, int(divisions) + 1)
    return MeshTri.init_tensor(ticks, ticks)


def disc_mesh(*, radius_m: float, refinements: int) -> MeshTri:
    """The disc of radius ``radius_m`` centred at the origin: scikit-fem's circle mesh refined
    ``refinements`` times (new boundary vertices on the circle; ``4 · 2^refinements`` boundary
    edges: an inscribed polygon)."""
    if isinstance(refinements, bool) or int(refinements) != refinements or refinements < 1:
        raise ValueError(f"refinements: must be an integer >= 1, got {refinements!r}")
    return MeshTri.init_circle(int(refinements)).scaled(check_positive("radius_m", radius_m))


def _plate_form(rigidity: PlateRigidity) -> BilinearForm:
    D11, D12, D66 = rigidity.D11_Nm, rigidity.D12_Nm, rigidity.D66_Nm

    @BilinearForm
    def bending(u, v, _):
        H, G = u.hess, v.hess
        return (
            D11 * (H[0, 0] * G[0, 0] + H[1, 1] * G[1, 1])
            + D12 * (H[0, 0] * G[1, 1] + H[1, 1] * G[0, 0])
            + 4.0 * D66 * H[0, 1] * G[0, 1]
        )

    return bending


@BilinearForm
def _mass_form(u, v, _):
    return u * v


@dataclass(frozen=True)
class KirchhoffModes:
    """Elastic modes of a free Kirchhoff plate (:func:`free_plate_modes`).

    Attributes:
      omega_rad_s: (k,) circular frequencies, ascending [rad/s].
      points_m: (n, 2) the mesh vertices [m].
      deflection: (k, n) each mode's ``w`` at the vertices, scaled to a largest ``|w|`` of 1.
      n_dofs: the finite-element unknowns.
    """

    omega_rad_s: np.ndarray
    points_m: np.ndarray
    deflection: np.ndarray
    n_dofs: int

    @property
    def frequencies_Hz(self) -> np.ndarray:
        """(k,) ``ω / 2π`` [Hz]."""
        return self.omega_rad_s / (2.0 * np.pi)


def _basis(mesh: MeshTri, element: str) -> Basis:
    if element not in _ELEMENTS:
        raise ValueError(f"element: must be one of {sorted(_ELEMENTS)}, got {element!r}")
    return Basis(mesh, _ELEMENTS[element]())


def free_plate_modes(
    mesh: MeshTri,
    rigidity: PlateRigidity,
    *,
    areal_density_kg_m2: float,
    count: int,
    element: Literal["argyris", "morley"] = "argyris",
) -> KirchhoffModes:
    """The ``count`` lowest elastic modes of the free plate on ``mesh`` (module docstring).

    Raises ``ValueError`` for a bad argument, or when the three lowest modes are not the rigid
    motions and only they (a mesh that is not one connected plate, or too coarse)."""
    rho = check_positive("areal_density_kg_m2", areal_density_kg_m2)
    if isinstance(count, bool) or int(count) != count or count < 1:
        raise ValueError(f"count: must be an integer >= 1, got {count!r}")
    basis = _basis(mesh, element)
    K, M = _plate_form(rigidity).assemble(basis), rho * _mass_form.assemble(basis)
    extent = float(np.ptp(mesh.p, axis=1).max())
    scale = rigidity.D11_Nm / (rho * extent**4)
    lam, phi = eigsh(K.tocsc(), k=int(count) + 3, M=M.tocsc(), sigma=-scale, which="LM")
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    rigid = np.abs(lam) < RIGID_REL * scale
    if not (np.all(rigid[:3]) and not np.any(rigid[3:])):
        raise ValueError(
            f"mesh: a free plate has 3 rigid modes, found {int(rigid.sum())} among ω² = {lam[:4].tolist()} rad²/s²"
        )
    w = phi[basis.nodal_dofs[0], 3:].T
    w = w / np.abs(w).max(axis=1, keepdims=True)
    return KirchhoffModes(omega_rad_s=np.sqrt(lam[3:]), points_m=mesh.p.T.copy(), deflection=w, n_dofs=K.shape[0])


def _disc_determinant(lam: float, n: int, nu: float) -> float:
    """The free disc's frequency determinant at ``λ`` (module docstring; ``I`` column over ``I_n``)."""
    J, dJ = jv(n, lam), jvp(n, lam)
    ratio = ivp(n, lam) / iv(n, lam) if lam < 50.0 else 0.5 * (ive(n - 1, lam) + ive(n + 1, lam)) / ive(n, lam)
    q = 1.0 - nu
    m_J = -(lam**2) * J + q * (n**2 * J - lam * dJ)
    v_J = -(lam**3) * dJ - q * n**2 * (lam * dJ - J)
    m_I = lam**2 + q * (n**2 - lam * ratio)
    v_I = lam**3 * ratio - q * n**2 * (lam * ratio - 1.0)
    return m_J * v_I - m_I * v_J


def free_disc_lambda2(*, nu: float, nodal_diameters: int, count: int, step: float = 0.01) -> np.ndarray:
    """The ``count`` lowest elastic ``λ² = ω R² √(ρ_A / D)`` of the isotropic free disc with
    ``nodal_diameters`` nodal diameters (0, 1, 2, …) and Poisson ratio ``nu`` (module docstring);
    entry ``s`` has ``s`` nodal circles (``s + 1`` for ``n = 0, 1``, whose ``λ = 0`` is rigid)."""
    if not -1.0 < nu < 1.0:
        raise ValueError(f"nu: must lie in (-1, 1), got {nu!r}")
    n = nodal_diameters
    if isinstance(n, bool) or int(n) != n or n < 0:
        raise ValueError(f"nodal_diameters: must be an integer >= 0, got {nodal_diameters!r}")
    if isinstance(count, bool) or int(count) != count or count < 1:
        raise ValueError(f"count: must be an integer >= 1, got {count!r}")
    roots: list[float] = []
    lo = 10.0 * check_positive("step", step)
    f_lo = _disc_determinant(lo, int(n), nu)
    while len(roots) < count:
        hi = lo + step
        f_hi = _disc_determinant(hi, int(n), nu)
        if f_lo == 0.0 or f_lo * f_hi < 0.0:
            roots.append(lo if f_lo == 0.0 else brentq(_disc_determinant, lo, hi, args=(int(n), nu), xtol=1e-14))
        lo, f_lo = hi, f_hi
    return np.asarray(roots) ** 2


def square_symmetry_class(points_m: np.ndarray, deflection: np.ndarray) -> list[str]:
    """The symmetry class of each deflection ``w`` (k, n) at points ``(x, y)`` (n, 2) of a shape
    with the square's symmetry about the origin: the parities ``p_x, p_y, p_s = ⟨w, w∘R⟩ / ⟨w, w⟩``
    under the mirrors ``x → −x``, ``y → −y`` and ``x ↔ y`` (the image is the nearest point), and

    ``A1`` (``p_x, p_y > 0``, ``p_s > 0``: e.g. ``x² + y² − c``), ``B1`` (``p_s < 0``: the saddle
    ``x² − y²``), ``B2`` (``p_x, p_y < 0``, ``p_s > 0``: the twist ``x y``), ``A2`` (``p_s < 0``:
    ``x y (x² − y²)``), ``E`` (odd in one axis, even in the other: a pair of equal frequencies), when
    ``p_x p_y`` is not above 0.5 ``E`` as well (a mixture within the pair)."""
    xy = np.asarray(points_m, dtype=float)[:, :2]
    w = np.atleast_2d(np.asarray(deflection, dtype=float))
    tree = cKDTree(xy)
    images = [tree.query(xy * sign)[1] for sign in (np.array([-1.0, 1.0]), np.array([1.0, -1.0]))]
    images.append(tree.query(xy[:, ::-1])[1])
    norm = np.einsum("kn,kn->k", w, w)
    px, py, ps = (np.einsum("kn,kn->k", w, w[:, i]) / norm for i in images)
    names = []
    for x, y, s in zip(px, py, ps):
        if x * y <= _PARITY_MIN:
            names.append("E")
        elif x > 0:
            names.append("A1" if s > 0 else "B1")
        else:
            names.append("B2" if s > 0 else "A2")
    return names


def cantilever_rigidity_factor(rigidity: PlateRigidity, *, divisions: int = 12) -> float:
    """``c = EI / (D11 d)`` of the square Kirchhoff plate clamped along ``x = −d/2`` and loaded
    along ``x = +d/2`` (module docstring; ``EI = P d³ / (3 δ)``, ``δ`` the mean tip deflection;
    independent of ``d``, computed on the unit square with the Argyris element)."""
    mesh = square_mesh(side_m=1.0, divisions=divisions)
    basis = _basis(mesh, "argyris")
    K = _plate_form(rigidity).assemble(basis)
    root = mesh.facets_satisfying(lambda x: np.isclose(x[0], -0.5))
    tip = mesh.facets_satisfying(lambda x: np.isclose(x[0], 0.5))
    clamped = basis.get_dofs(root).all(["u", "u_x", "u_y", "u_xy", "u_yy", "u_n"])

    @LinearForm
    def line_load(v, _):
        return v  # P / d = 1 on the unit square

    f = line_load.assemble(FacetBasis(mesh, basis.elem, facets=tip))
    w = np.zeros(K.shape[0])
    free = np.setdiff1d(np.arange(K.shape[0]), clamped)
    w[free] = spsolve(*condense(K, f, D=clamped, expand=False))
    delta = float(f @ w)  # ∫ (P/d) w ds = P δ with P = 1
    return 1.0 / (3.0 * delta * rigidity.D11_Nm)
