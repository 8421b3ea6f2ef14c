"""Flat surfaces for SRP and drag: optical coefficients, facet sets and the vectorised force laws.

**SRP** — the non-ideal flat-sail model of McInnes as used by Yoo et al. 2016, Eqs. 16–22
(its Table 3 labels read as the symbols below, B_f for the printed b_f in Eq. 16, and the
tangential force taken away from the Sun). For a facet of area A with unit normal n̂ (front face), Sun unit vector
ŝ (from the facet to the Sun) and c = ŝ·n̂: the lit face has normal n̂_l = sign(c) n̂ and
cos α = |c|; its coefficients are (B_l, e_l, B_d, e_d) = (B_f, e_f, B_b, e_b) when the front is
lit and, for two-sided facets with ``swap_back`` (default), (B_b, e_b, B_f, e_f) when the back is
lit. With κ = (e_l B_l − e_d B_d)/(e_l + e_d):

    F = −P A cos α [((1 + r s) cos α + B_l r (1 − s) + (1 − r) κ) n̂_l + (1 − r s) sin α t̂],

t̂ = (ŝ − cos α n̂_l)/sin α (the tangential force points away from the Sun; the paper prints a + sign). Using
sin α t̂ = ŝ − cos α n̂_l exactly, the implementation evaluates the equivalent form

    F = −P A cos α [(1 − r s) ŝ + (2 r s cos α + B_l r (1 − s) + (1 − r) κ) n̂_l],

which needs no division by sin α. Limits: r = s = 1 at normal incidence gives −2PA n̂; r = 0 with
e_f = e_b and B_f = B_b gives −PA cos α ŝ. One-sided facets (e.g. bus faces) feel nothing when
their back faces the Sun.

**Drag** — free-molecular flat plate, force opposite the flow (Yoo et al. 2016, Eqs. 13–15):

    F = −½ C_d ρ |V| V A_proj,   A_proj = A |n̂·V̂| (two-sided) or A max(n̂·V̂, 0) (one-sided),

with V the velocity of the surface relative to the atmosphere.

Vectors are in whatever frame the caller uses (world = ECI axes in the loads).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import csr_matrix

from magsail_mj.checks import require_non_negative

__all__ = [
    "Optics",
    "FacetSet",
    "optics_arrays",
    "srp_forces",
    "drag_forces",
    "quad_area_vectors",
    "cell_node_matrix",
    "lattice_top_cells",
    "CellGeometry",
    "uniform_srp_constants",
]


@dataclass(frozen=True)
class Optics:
    """Optical coefficients of a surface (Yoo et al. 2016, Table 3, read by symbol: its "emission" and
    "non-Lambertian" labels are swapped).

    r: reflectivity; s: specular fraction of the reflection; B_f, B_b: non-Lambertian
    coefficients of the front and back; e_f, e_b: emissivities of front and back;
    swap_back: when the back of a two-sided surface is lit, swap the front/back coefficients
    (the physical choice; ``False`` keeps the paper's literal reading).
    """

    r: float = 0.0
    s: float = 0.0
    B_f: float = 2.0 / 3.0
    B_b: float = 2.0 / 3.0
    e_f: float = 1.0
    e_b: float = 1.0
    swap_back: bool = True

    def __post_init__(self) -> None:
        for name in ("r", "s"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{name}: must be in [0, 1], got {v!r}")
        require_non_negative(self, ("B_f", "B_b", "e_f", "e_b"))

    @classmethod
    def absorber(cls) -> "Optics":
        """Black surface: F = −P A cos α ŝ."""
        return cls()

    @classmethod
    def mirror(cls) -> "Optics":
        """Perfect specular reflector: F = −2 P A cos²α n̂_l."""
        return cls(r=1.0, s=1.0)

    @classmethod
    def cnusail_sail(cls) -> "Optics":
        """Aluminised Kapton sail of CNUSAIL-1 (r 0.88, s 0.94, B_f 0.79, B_b 0.55, e_f 0.05, e_b 0.55)."""
        return cls(r=0.88, s=0.94, B_f=0.79, B_b=0.55, e_f=0.05, e_b=0.55)


@dataclass
class FacetSet:
    """Flat facets fixed in one body.

    Attributes:
      area: (n,) areas [m²].
      normal: (n, 3) unit front normals in body components.
      centre: (n, 3) centres of pressure relative to the body's centre of mass, body components [m].
      two_sided: (n,) whether the back face also takes loads (membranes) or not (box faces).
      optics: one :class:`Optics` per facet (or one for all).
    """

    area: np.ndarray
    normal: np.ndarray
    centre: np.ndarray
    two_sided: np.ndarray
    optics: list[Optics] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.area = np.atleast_1d(np.asarray(self.area, dtype=float))
        n = len(self.area)
        self.normal = np.asarray(self.normal, dtype=float).reshape(n, 3)
        self.normal = self.normal / np.linalg.norm(self.normal, axis=1, keepdims=True)
        self.centre = np.asarray(self.centre, dtype=float).reshape(n, 3)
        self.two_sided = np.broadcast_to(np.asarray(self.two_sided, dtype=bool), (n,)).copy()
        if np.any(self.area < 0):
            raise ValueError(f"area: facet areas must be >= 0 m², got {self.area.tolist()}")
        if isinstance(self.optics, Optics):
            self.optics = [self.optics] * n
        if not self.optics:
            self.optics = [Optics()] * n
        if len(self.optics) != n:
            raise ValueError(f"optics: need one Optics per facet ({n}), got {len(self.optics)}")
        self.coeffs = optics_arrays(self.optics)

    def __len__(self) -> int:
        return len(self.area)

    @classmethod
    def plate(
        cls,
        *,
        area: float,
        normal=(0.0, 0.0, 1.0),
        centre=(0.0, 0.0, 0.0),
        optics: Optics | None = None,
        two_sided: bool = True,
    ) -> "FacetSet":
        """One flat plate (a sail membrane by default: two-sided)."""
        return cls(area=[area], normal=[normal], centre=[centre], two_sided=[two_sided], optics=[optics or Optics()])

    @classmethod
    def box(cls, *, size, centre=(0.0, 0.0, 0.0), optics: Optics | None = None) -> "FacetSet":
        """The six one-sided outer faces of a box of edge lengths ``size`` (3,) [m] centred at
        ``centre`` (relative to the centre of mass, body axes)."""
        sx, sy, sz = (float(v) for v in size)
        c = np.asarray(centre, dtype=float)
        normals = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
        half = np.array([sx, sx, sy, sy, sz, sz]) / 2
        areas = np.array([sy * sz, sy * sz, sx * sz, sx * sz, sx * sy, sx * sy])
        return cls(
            area=areas,
            normal=normals,
            centre=c + normals * half[:, None],
            two_sided=np.zeros(6, bool),
            optics=[optics or Optics()] * 6,
        )

    @classmethod
    def concat(cls, sets: list["FacetSet"]) -> "FacetSet":
        """All facets of several sets (same body)."""
        return cls(
            area=np.concatenate([s.area for s in sets]),
            normal=np.concatenate([s.normal for s in sets]),
            centre=np.concatenate([s.centre for s in sets]),
            two_sided=np.concatenate([s.two_sided for s in sets]),
            optics=[o for s in sets for o in s.optics],
        )


def optics_arrays(optics: list[Optics]) -> dict[str, np.ndarray]:
    """Per-facet coefficient arrays (r, s, B_f, B_b, e_f, e_b, swap) of a list of :class:`Optics`."""
    keys = ("r", "s", "B_f", "B_b", "e_f", "e_b", "swap_back")
    return {k: np.array([getattr(o, k) for o in optics], dtype=float if k != "swap_back" else bool) for k in keys}


def srp_forces(
    normal: np.ndarray,
    area: np.ndarray,
    sun: np.ndarray,
    pressure: float,
    coeffs: dict[str, np.ndarray],
    two_sided: np.ndarray | bool = True,
) -> np.ndarray:
    """SRP force on each facet (n, 3) [N] (module docstring).

    Args:
      normal: (n, 3) unit front normals; area: (n,) [m²]; sun: (3,) unit vector to the Sun (same
      frame); pressure: P at the facet [N/m²] (0 in shadow); coeffs: :func:`optics_arrays` output
      (arrays of length n or 1); two_sided: (n,) or scalar.
    """
    c = normal @ sun
    front = c >= 0.0
    cos_a = np.abs(c)
    lit = np.where(front, True, two_sided)
    sign = np.where(front, 1.0, -1.0)
    r, s = coeffs["r"], coeffs["s"]
    swap = (~front) & coeffs["swap_back"]
    B_l = np.where(swap, coeffs["B_b"], coeffs["B_f"])
    B_d = np.where(swap, coeffs["B_f"], coeffs["B_b"])
    e_l = np.where(swap, coeffs["e_b"], coeffs["e_f"])
    e_d = np.where(swap, coeffs["e_f"], coeffs["e_b"])
    esum = e_l + e_d
    kappa = np.divide(e_l * B_l - e_d * B_d, esum, out=np.zeros(np.broadcast(esum, c).shape), where=esum > 0)
    rs = r * s
    k_n = (2.0 * rs * cos_a + B_l * r * (1.0 - s) + (1.0 - r) * kappa) * sign
    scale = np.where(lit, -pressure * area * cos_a, 0.0)
    k_s = np.broadcast_to(1.0 - rs, c.shape)
    return scale[:, None] * (k_s[:, None] * sun + k_n[:, None] * normal)


def drag_forces(
    normal: np.ndarray,
    area: np.ndarray,
    v_rel: np.ndarray,
    density: float,
    cd: float,
    two_sided: np.ndarray | bool = True,
) -> np.ndarray:
    """Drag force on each facet (n, 3) [N]: −½ C_d ρ |V| V A_proj (module docstring).

    ``v_rel`` is (3,) (one flow for all facets) or (n, 3) (per-facet flow velocity).
    """
    v_rel = np.asarray(v_rel, dtype=float)
    speed = np.linalg.norm(v_rel, axis=-1)
    if np.all(speed == 0.0) or density == 0.0:
        return np.zeros((len(area), 3))
    if v_rel.ndim == 1:
        cproj = normal @ v_rel  # = |V| n̂·V̂
        proj = np.where(two_sided, np.abs(cproj), np.maximum(cproj, 0.0))
        return (-0.5 * cd * density * area * proj)[:, None] * v_rel
    cproj = np.einsum("ij,ij->i", normal, v_rel)
    proj = np.where(two_sided, np.abs(cproj), np.maximum(cproj, 0.0))
    return (-0.5 * cd * density * area * proj)[:, None] * v_rel


def quad_area_vectors(p: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Vector areas (ncell, 3) of quadrilateral cells with corner indices ``cells`` (ncell, 4)
    into points ``p`` (npts, 3): A⃗ = ½ (p2 − p0) × (p3 − p1), exact for planar quads and the
    projected (mean) vector area of a warped one. Corners counter-clockwise about the front
    normal, e.g. (i, j), (i+1, j), (i+1, j+1), (i, j+1) for a +z normal."""
    p0, p1, p2, p3 = (p[cells[:, k]] for k in range(4))
    return 0.5 * np.cross(p2 - p0, p3 - p1)


def cell_node_matrix(cells: np.ndarray, nrows: int, *, offset: int = 0):
    """Sparse (nrows, ncell) matrix S with S[cells[c, k] + offset, c] = ¼: ``S @ F_cell`` shares
    each cell's force equally among its four corners (scatter without Python loops)."""
    cells = np.asarray(cells, dtype=np.int64)
    ncell = len(cells)
    rows = cells.ravel() + offset
    cols = np.repeat(np.arange(ncell), 4)
    return csr_matrix((np.full(4 * ncell, 0.25), (rows, cols)), shape=(nrows, ncell))


def lattice_top_cells(n: int) -> np.ndarray:
    """Top-layer cells (ncell = (n−1)², 4) of a two-layer n × n lattice with node flat index
    k n² + j n + i (k = 1 top): corners (i, j), (i+1, j), (i+1, j+1), (i, j+1), counter-clockwise
    about +z, so the cell normal is the top layer's outward normal (+z₁)."""
    if n < 2:
        raise ValueError(f"n: nodes per side must be >= 2, got {n!r}")
    j, i = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    base = n * n + j * n + i
    return np.stack([base, base + 1, base + n + 1, base + n], -1).reshape(-1, 4)


def uniform_srp_constants(optics: Optics) -> tuple[float, float, float, float]:
    """Constants of :func:`srp_forces` for one set of coefficients: (r s, K_front, K_back,
    1 − r s) with K = B_l r (1 − s) + (1 − r) κ for the front-lit and back-lit cases."""
    o = optics

    def K(B_l: float, e_l: float, B_d: float, e_d: float) -> float:
        kappa = (e_l * B_l - e_d * B_d) / (e_l + e_d) if e_l + e_d > 0 else 0.0
        return B_l * o.r * (1.0 - o.s) + (1.0 - o.r) * kappa

    k_front = K(o.B_f, o.e_f, o.B_b, o.e_b)
    k_back = K(o.B_b, o.e_b, o.B_f, o.e_f) if o.swap_back else k_front
    return o.r * o.s, k_front, k_back, 1.0 - o.r * o.s


class CellGeometry:
    """Index work for quadrilateral cells, built once: current vector areas, unit normals and
    mean corner velocities of all cells, and the scatter of cell forces to the corner bodies.

    Works in a (3, ncell) component-major layout (contiguous rows make the per-step arithmetic
    several times cheaper than on (ncell, 3) arrays). ``body_cells`` are body indices.
    """

    def __init__(self, body_cells: np.ndarray) -> None:
        body_cells = np.asarray(body_cells, dtype=np.int64)
        if body_cells.ndim != 2 or body_cells.shape[1] != 4:
            raise ValueError(f"cells: must have shape (ncell, 4), got {body_cells.shape}")
        self.body_cells = body_cells
        self.ncell = len(body_cells)
        self._flat = np.ascontiguousarray(body_cells.T).ravel()  # corner-major
        self._S = None
        self._flat_idx: tuple[int, np.ndarray] | None = None

    def corners(self, arr: np.ndarray) -> np.ndarray:
        """Gather (3, 4, ncell) corner values of an (nbody, 3) array."""
        return np.take(arr.T, self._flat, axis=1).reshape(3, 4, self.ncell)

    def area_normal(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Areas (ncell,) and unit normals (3, ncell) from body positions ``pos`` (nbody, 3):
        A⃗ = ½ (p2 − p0) × (p3 − p1) (:func:`quad_area_vectors`)."""
        G = self.corners(pos)
        d1 = G[:, 2] - G[:, 0]
        d2 = G[:, 3] - G[:, 1]
        A = np.empty_like(d1)
        np.multiply(d1[1], d2[2], out=A[0])
        A[0] -= d1[2] * d2[1]
        np.multiply(d1[2], d2[0], out=A[1])
        A[1] -= d1[0] * d2[2]
        np.multiply(d1[0], d2[1], out=A[2])
        A[2] -= d1[1] * d2[0]
        area2 = np.sqrt(A[0] * A[0] + A[1] * A[1] + A[2] * A[2])  # = 2 × area
        A /= area2
        return 0.5 * area2, A

    def mean_velocity(self, vel: np.ndarray) -> np.ndarray:
        """Mean corner velocity (3, ncell) of each cell."""
        G = self.corners(vel)
        return 0.25 * (G[:, 0] + G[:, 1] + G[:, 2] + G[:, 3])

    def scatter(self, F: np.ndarray, xfrc: np.ndarray) -> None:
        """Add ¼ of each cell force ``F`` (3, ncell) to the force rows of its corner bodies.

        One ``bincount`` over the flat (nbody × ncol) wrench array when it is C-contiguous
        (``MjData.xfrc_applied`` is), else a sparse product.
        """
        if xfrc.flags.c_contiguous:
            ncol = xfrc.shape[1]
            if self._flat_idx is None or self._flat_idx[0] != ncol:
                idx = (self.body_cells.T[:, None, :] * ncol + np.arange(3)[None, :, None]).ravel()
                self._flat_idx = (ncol, idx)
            w = np.broadcast_to(0.25 * F, (4, 3, self.ncell)).ravel()
            flat = xfrc.reshape(-1)
            flat += np.bincount(self._flat_idx[1], w, minlength=flat.size)
            return
        if self._S is None or self._S.shape[0] != xfrc.shape[0]:
            self._S = cell_node_matrix(self.body_cells, xfrc.shape[0])
        xfrc[:, :3] += self._S @ F.T
