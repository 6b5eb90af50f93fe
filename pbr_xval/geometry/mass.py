"""Mass properties of a rock: exact surface integrals and the seed's grid-node estimate.

* :func:`exact_mass_properties` — volume, centre of mass and inertia tensor integrated exactly
  over the closed triangle mesh (trimesh's divergence-theorem integrals).
* :func:`node_mass_properties` — the seed's route (§5): equally spaced grid nodes inside the
  rock, each carrying a cube of side h (mass ρh³); the inertia is the sum of the point-mass
  terms plus each cube's own inertia about its centre, m·h²/6 on every axis.

Both return a :class:`MassProperties` (inertia about the COM, in the input axes, with its
principal moments and axes). Give either a density (kg/m³) or a total mass (kg).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import trimesh

__all__ = [
    "MassProperties",
    "compare_mass_properties",
    "exact_mass_properties",
    "grid_nodes_in_mesh",
    "node_mass_properties",
    "principal",
]


@dataclass
class MassProperties:
    """Mass properties of a uniform solid (SI units).

    Attributes
    ----------
    volume : m³.
    mass : kg.
    density : kg/m³.
    com : (3,) m.
    inertia : (3, 3) kg·m² about the COM, input axes.
    principal_moments : (3,) kg·m², ascending.
    principal_axes : (3, 3) columns are the principal axes (right-handed).
    method : "exact" or "nodes".
    n_nodes, spacing : for the node method.
    """

    volume: float
    mass: float
    density: float
    com: np.ndarray
    inertia: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    method: str
    n_nodes: int | None = None
    spacing: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """Mass (kg), volume (m³), COM (3,) m and inertia (3, 3) kg·m² as plain JSON values."""
        d = asdict(self)
        return {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in d.items()}


def principal(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(moments ascending (3,), axes as columns (3, 3), right-handed) of a symmetric tensor."""
    w, v = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(v) < 0:
        v[:, 2] = -v[:, 2]
    return w, v


def _density(volume: float, density: float | None, mass: float | None) -> float:
    if (density is None) == (mass is None):
        raise ValueError("give exactly one of density (kg/m³) or mass (kg)")
    if density is not None:
        if not density > 0:
            raise ValueError(f"density must be > 0 kg/m³, got {density}")
        return float(density)
    if not (mass is not None and mass > 0):
        raise ValueError(f"mass must be > 0 kg, got {mass}")
    return float(mass) / volume


def exact_mass_properties(
    mesh: trimesh.Trimesh, *, density: float | None = None, mass: float | None = None
) -> MassProperties:
    """Exact integrals over the closed, outward-wound ``mesh``."""
    vol = float(mesh.volume)
    if not vol > 0:
        raise ValueError(f"the mesh volume is {vol} m³; expected a closed outward-wound solid")
    rho = _density(vol, density, mass)
    m = mesh.copy()
    m.density = rho
    mp = m.mass_properties
    inertia = np.asarray(mp["inertia"], dtype=float)
    w, ax = principal(inertia)
    return MassProperties(vol, rho * vol, rho, np.asarray(mp["center_mass"], float), inertia, w, ax, "exact")


def node_mass_properties(
    nodes: np.ndarray, spacing: float, *, density: float | None = None, mass: float | None = None
) -> MassProperties:
    """The seed's estimate from equally spaced nodes (n, 3) with grid spacing ``spacing`` (m)."""
    p = np.asarray(nodes, dtype=float)
    if len(p) == 0:
        raise ValueError(f"no grid nodes inside the solid at spacing {spacing} m; use a finer grid")
    h3 = float(spacing) ** 3
    vol = len(p) * h3
    rho = _density(vol, density, mass)
    m_node = rho * h3
    com = p.mean(axis=0)
    r = p - com
    inertia = m_node * (np.sum(r * r) * np.eye(3) - r.T @ r)
    inertia += len(p) * m_node * spacing**2 / 6.0 * np.eye(3)  # each node's own cube
    w, ax = principal(inertia)
    return MassProperties(vol, rho * vol, rho, com, inertia, w, ax, "nodes", len(p), float(spacing))


def grid_nodes_in_mesh(mesh: trimesh.Trimesh, spacing: float, origin: np.ndarray | None = None) -> np.ndarray:
    """Centres of the grid cells of side ``spacing`` lying inside the closed ``mesh`` (n, 3).

    Inside/outside by ray parity along +z, vectorised: every triangle is rasterised onto the
    columns (x, y) of the grid, the crossing heights are sorted per column, and a node is inside
    when an odd number of crossings lies below it. The grid is anchored at ``origin`` (default:
    the lower bound shifted by an irrational fraction of a cell, so no column grazes an edge).
    """
    h = float(spacing)
    lo, hi = mesh.bounds
    if origin is None:
        origin = lo + h * np.array([0.5 - 0.0913, 0.5 - 0.0371, 0.5])
    origin = np.asarray(origin, float)
    nx, ny, nz = (np.floor((hi - origin) / h).astype(int) + 1).tolist()
    tri = mesh.triangles  # (m, 3, 3)
    txy = tri[:, :, :2]
    ix0 = np.ceil((txy[:, :, 0].min(1) - origin[0]) / h).astype(np.int64).clip(0, nx)
    ix1 = np.floor((txy[:, :, 0].max(1) - origin[0]) / h).astype(np.int64).clip(-1, nx - 1)
    iy0 = np.ceil((txy[:, :, 1].min(1) - origin[1]) / h).astype(np.int64).clip(0, ny)
    iy1 = np.floor((txy[:, :, 1].max(1) - origin[1]) / h).astype(np.int64).clip(-1, ny - 1)
    cx = np.maximum(ix1 - ix0 + 1, 0)
    cy = np.maximum(iy1 - iy0 + 1, 0)
    cnt = cx * cy
    tid = np.repeat(np.arange(len(tri)), cnt)
    if len(tid) == 0:
        return np.zeros((0, 3))
    k = np.arange(len(tid)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    gx = ix0[tid] + k % cx[tid]
    gy = iy0[tid] + k // cx[tid]
    px = origin[0] + gx * h
    py = origin[1] + gy * h
    a, b, c = tri[tid, 0], tri[tid, 1], tri[tid, 2]
    d = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    ok = np.abs(d) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((px - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (py - a[:, 1])) / d
        l2 = ((b[:, 0] - a[:, 0]) * (py - a[:, 1]) - (px - a[:, 0]) * (b[:, 1] - a[:, 1])) / d
        l0 = 1 - l1 - l2
    hit = ok & (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
    z = l0 * a[:, 2] + l1 * b[:, 2] + l2 * c[:, 2]
    col = (gx * ny + gy)[hit]
    z = z[hit]
    order = np.lexsort((z, col))
    col, z = col[order], z[order]
    # per column: nodes at iz with z_node = origin_z + iz*h; count crossings below
    ucol, start, ncross = np.unique(col, return_index=True, return_counts=True)
    out = []
    zn = origin[2] + np.arange(nz) * h
    for u, s, n in zip(ucol, start, ncross, strict=True):
        if n < 2:
            continue
        below = np.searchsorted(z[s : s + n], zn)
        inside = (below % 2) == 1
        if inside.any():
            gxu, gyu = divmod(int(u), ny)
            zz = zn[inside]
            out.append(
                np.column_stack(
                    [np.full(len(zz), origin[0] + gxu * h), np.full(len(zz), origin[1] + gyu * h), zz]
                )
            )
    return np.concatenate(out) if out else np.zeros((0, 3))


def compare_mass_properties(
    mesh: trimesh.Trimesh,
    spacing: float,
    *,
    density: float | None = None,
    mass: float | None = None,
    nodes: np.ndarray | None = None,
) -> dict[str, Any]:
    """Exact and node-based properties side by side, with relative differences.

    ``nodes`` defaults to :func:`grid_nodes_in_mesh` at ``spacing``. With ``mass`` given, both
    methods use the density implied by the exact volume.
    """
    ex = exact_mass_properties(mesh, density=density, mass=mass)
    if nodes is None:
        nodes = grid_nodes_in_mesh(mesh, spacing)
    nd = node_mass_properties(nodes, spacing, density=ex.density)
    size = float(np.ptp(mesh.vertices, axis=0).max())
    inorm = float(np.linalg.norm(ex.inertia))
    return {
        "exact": ex,
        "nodes": nd,
        "rel_volume": (nd.volume - ex.volume) / ex.volume,
        "com_offset_over_size": float(np.linalg.norm(nd.com - ex.com)) / size,
        "rel_inertia": float(np.linalg.norm(nd.inertia - ex.inertia)) / inorm,
        "rel_principal": ((nd.principal_moments - ex.principal_moments) / ex.principal_moments).tolist(),
    }
