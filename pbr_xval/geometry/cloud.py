"""Point cloud → solid rock, the seed's route (§5).

1. Delaunay tetrahedralisation of the scanned points (scipy / Qhull);
2. alpha filtering: keep the tetrahedra whose circumradius is ≤ alpha (default: a multiple of
   the median nearest-neighbour spacing); the union of kept tets is the solid. Cavities that do
   not reach the outside are filled (a rock has no internal voids) and only the largest
   face-connected piece is kept;
3. the boundary faces (faces of exactly one kept tet), wound outward, are the watertight surface
   the engines need. If that surface is not manifold, alpha is raised step by step; as a last
   resort the convex hull is used — every such step is recorded in ``warnings``;
4. equally spaced grid nodes inside (cell centres whose Delaunay simplex is kept) for the seed's
   node-based mass properties.

:func:`reconstruction_sensitivity` tabulates volume, COM and inertia over a few alpha
multiples and grid spacings with their relative spreads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, Delaunay, cKDTree

from pbr_xval.geometry.io import GeometryError, check_points, fix_winding

__all__ = [
    "DEFAULT_ALPHA_MULTIPLE",
    "AlphaSolid",
    "alpha_solid",
    "circumradii",
    "face_circumradii",
    "median_spacing",
    "reconstruction_sensitivity",
]

DEFAULT_ALPHA_MULTIPLE = 8.0
#: fewest points a closed surface is reconstructed from (a rock's shape, contact and tilt need many)
MIN_CLOUD_POINTS = 100
MIN_HULL_FRACTION = 0.5  # a solid below this fraction of its hull volume means the carving leaked in
_FACE_OPPOSITE = np.array(
    [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]]
)  # face opposite vertex j, outward for + volume


def median_spacing(points: np.ndarray) -> float:
    """Median distance from each point to its nearest neighbour (m)."""
    d, _ = cKDTree(points).query(points, k=2)
    return float(np.median(d[:, 1]))


def circumradii(points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
    """Circumradius of each tetrahedron (m); inf for flat ones."""
    a = points[simplices[:, 0]]
    u, v, w = (points[simplices[:, k]] - a for k in (1, 2, 3))
    vw, wu, uv = np.cross(v, w), np.cross(w, u), np.cross(u, v)
    den = 2.0 * np.einsum("ij,ij->i", u, vw)
    num = (u * u).sum(1)[:, None] * vw + (v * v).sum(1)[:, None] * wu + (w * w).sum(1)[:, None] * uv
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.linalg.norm(num, axis=1) / np.abs(den)
    r[~np.isfinite(r)] = np.inf
    return r


@dataclass
class AlphaSolid:
    """A solid reconstructed from a point cloud.

    Attributes
    ----------
    points : (n, 3) input points (local frame, m).
    delaunay : scipy Delaunay of the points.
    kept : (n_tets,) bool — the tets forming the solid.
    alpha : circumradius threshold used (m); ``alpha_multiple`` × ``spacing``.
    spacing : median nearest-neighbour distance of the points (m).
    mesh : watertight outward-wound boundary surface (trimesh).
    method : "alpha" or "convex_hull" (fallback).
    warnings : what was changed to get a manifold surface.
    """

    points: np.ndarray
    delaunay: Delaunay
    kept: np.ndarray
    alpha: float
    alpha_multiple: float
    spacing: float
    mesh: trimesh.Trimesh
    method: str
    warnings: list[str] = field(default_factory=list)

    @property
    def volume(self) -> float:
        """Sum of the kept tetrahedra volumes (m³); equals the boundary mesh volume."""
        p, s = self.points, self.delaunay.simplices[self.kept]
        a = p[s[:, 0]]
        return float(
            np.abs(np.einsum("ij,ij->i", p[s[:, 1]] - a, np.cross(p[s[:, 2]] - a, p[s[:, 3]] - a))).sum() / 6
        )

    def grid_nodes(self, spacing: float, method: str = "surface") -> np.ndarray:
        """Cell centres of a regular grid of side ``spacing`` inside the solid (n, 3).

        ``method="simplex"`` is the seed's test (Delaunay.find_simplex restricted to the kept
        tets; slow on big clouds); ``"surface"`` (default) uses ray parity on the boundary mesh,
        which bounds exactly the union of kept tets — same answer, much faster.
        """
        if method == "surface":
            from pbr_xval.geometry.mass import grid_nodes_in_mesh

            return grid_nodes_in_mesh(self.mesh, spacing)
        h = float(spacing)
        lo, hi = self.points.min(0), self.points.max(0)
        origin = lo + h * np.array([0.5 - 0.0913, 0.5 - 0.0371, 0.5 - 0.0217])
        axes = [origin[k] + h * np.arange(int(np.floor((hi[k] - origin[k]) / h)) + 1) for k in range(3)]
        out = []
        gx, gy = np.meshgrid(axes[0], axes[1], indexing="ij")
        gx, gy = gx.ravel(), gy.ravel()
        for z in axes[2]:  # slab by slab keeps memory small
            q = np.column_stack([gx, gy, np.full(len(gx), z)])
            s = self.delaunay.find_simplex(q)
            inside = s >= 0
            inside[inside] = self.kept[s[inside]]
            if inside.any():
                out.append(q[inside])
        return np.concatenate(out) if out else np.zeros((0, 3))

    def to_dict(self) -> dict[str, Any]:
        """The alpha solid's parameters and checks as plain JSON values (lengths in m)."""
        return {
            "method": self.method,
            "alpha_m": self.alpha,
            "alpha_multiple": self.alpha_multiple,
            "point_spacing_m": self.spacing,
            "n_points": len(self.points),
            "n_tets_kept": int(self.kept.sum()),
            "n_tets": len(self.kept),
            "volume_m3": self.volume,
            "warnings": list(self.warnings),
        }


def _tet_graph(neighbors: np.ndarray, mask: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of the tets in ``mask`` linked through shared faces."""
    idx = np.nonzero(mask)[0]
    nb = neighbors[idx]
    rows = np.repeat(idx, 4)
    cols = nb.ravel()
    ok = (cols >= 0) & mask[np.where(cols >= 0, cols, 0)]
    n = len(mask)
    g = coo_matrix((np.ones(int(ok.sum())), (rows[ok], cols[ok])), shape=(n, n))
    return connected_components(g, directed=False)


def face_circumradii(points: np.ndarray, simplices: np.ndarray) -> np.ndarray:
    """(n_tets, 4) circumradius of the triangle opposite each vertex of each tetrahedron (m)."""
    out = np.empty((len(simplices), 4))
    for j in range(4):
        f = simplices[:, _FACE_OPPOSITE[j]]
        a, b, c = points[f[:, 0]], points[f[:, 1]], points[f[:, 2]]
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (b - c, c - a, a - b))
        area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)  # 2K
        with np.errstate(divide="ignore", invalid="ignore"):
            r = la * lb * lc / (2.0 * area2)
        r[~np.isfinite(r)] = np.inf
        out[:, j] = r
    return out


def _select(
    dl: Delaunay,
    radii: np.ndarray,
    face_radii: np.ndarray,
    alpha: float,
    criterion: str,
    closed_base: bool,
    down: np.ndarray,
) -> np.ndarray:
    n = len(dl.simplices)
    nb = dl.neighbors
    if criterion == "tet":
        kept = radii <= alpha
    else:
        # carve from the outside: a ball of radius alpha passes through a face whose circle is larger
        passable = face_radii > alpha
        inner = (nb >= 0) & passable
        i_idx = np.repeat(np.arange(n), 4).reshape(n, 4)[inner]
        j_idx = nb[inner]
        entry = (nb < 0) & passable
        if closed_base:  # the pedestal closes the (occluded) base: no entry through downward hull faces
            entry &= ~down
        hull_in = np.any(entry, axis=1)  # tets the outside reaches directly
        rows = np.concatenate([i_idx, np.nonzero(hull_in)[0]])
        cols = np.concatenate([j_idx, np.full(int(hull_in.sum()), n)])
        g = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n + 1, n + 1))
        _, lab = connected_components(g, directed=False)
        kept = lab[:n] != lab[n]
    if not kept.any():
        return kept
    # fill cavities: non-kept tets that cannot reach the hull boundary through non-kept tets
    free = ~kept
    ncomp, lab = _tet_graph(nb, free)
    outside = np.zeros(ncomp, bool)
    touches = free & np.any(nb < 0, axis=1)
    outside[np.unique(lab[touches])] = True
    kept = kept | (free & ~outside[lab])
    # largest face-connected piece of the solid
    ncomp, lab = _tet_graph(nb, kept)
    sizes = np.bincount(lab[kept], minlength=ncomp)
    return kept & (lab == np.argmax(sizes))


def _boundary_faces(points: np.ndarray, dl: Delaunay, kept: np.ndarray) -> np.ndarray:
    s = dl.simplices
    # orient every tet positively so _FACE_OPPOSITE gives outward faces
    a = points[s[:, 0]]
    vol = np.einsum("ij,ij->i", points[s[:, 1]] - a, np.cross(points[s[:, 2]] - a, points[s[:, 3]] - a))
    faces = []
    for j in range(4):
        nb = dl.neighbors[:, j]
        bnd = kept & ((nb < 0) | ~kept[np.where(nb >= 0, nb, 0)])
        f = s[bnd][:, _FACE_OPPOSITE[j]]
        neg = vol[bnd] < 0
        f[neg] = f[neg][:, ::-1]
        faces.append(f)
    return np.concatenate(faces)


def _bad_edges(faces: np.ndarray) -> np.ndarray:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return u[c != 2]


def _to_mesh(points: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    m = trimesh.Trimesh(vertices=points, faces=faces, process=False)
    m.remove_unreferenced_vertices()
    return m


def _downward_hull_faces(p: np.ndarray, dl: Delaunay) -> np.ndarray:
    """(n_tets, 4) True for convex-hull faces whose outward normal has z < -0.5."""
    s = dl.simplices
    out = np.zeros(s.shape, bool)
    for j in range(4):
        hull = dl.neighbors[:, j] < 0
        if not hull.any():
            continue
        f = s[hull][:, _FACE_OPPOSITE[j]]
        a, b, c = p[f[:, 0]], p[f[:, 1]], p[f[:, 2]]
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
        inward = (p[s[hull][:, j]] - a) @ np.eye(3)
        sgn = np.sign(np.einsum("ij,ij->i", n, inward))
        n = -n * sgn[:, None]  # outward
        out[np.nonzero(hull)[0], j] = n[:, 2] < -0.5
    return out


def _fill_pinches(
    p: np.ndarray, dl: Delaunay, kept: np.ndarray, rounds: int = 12
) -> tuple[np.ndarray, trimesh.Trimesh, int]:
    """Add the tets around edges shared by more than two boundary faces (pinches) until none remain."""
    s = dl.simplices
    order = np.argsort(s.ravel(), kind="stable")
    tet_of = order // 4
    starts = np.searchsorted(s.ravel()[order], np.arange(len(p) + 1))
    n_fixed = 0
    faces = _boundary_faces(p, dl, kept)
    for _ in range(rounds):
        bad = _bad_edges(faces)
        if len(bad) == 0:
            break
        n_fixed += len(bad)
        kept = kept.copy()
        for a, b in bad:
            ta = tet_of[starts[a] : starts[a + 1]]
            tb = tet_of[starts[b] : starts[b + 1]]
            kept[np.intersect1d(ta, tb)] = True
        faces = _boundary_faces(p, dl, kept)
    return kept, _to_mesh(p, faces), n_fixed


def alpha_solid(
    points: np.ndarray,
    *,
    alpha: float | None = None,
    alpha_multiple: float | None = None,
    max_tries: int = 8,
    criterion: str = "carve",
    closed_base: bool = True,
    name: str = "point cloud",
) -> AlphaSolid:
    """Reconstruct a watertight solid from ``points`` (n, 3) m by Delaunay + alpha filtering.

    Parameters
    ----------
    alpha : circumradius threshold (m); overrides ``alpha_multiple``.
    alpha_multiple : alpha as a multiple of the median nearest-neighbour spacing
        (default :data:`DEFAULT_ALPHA_MULTIPLE`).
    criterion : ``"carve"`` (default) removes tetrahedra reachable from the outside through
        faces whose circumcircle is larger than alpha (a ball of radius alpha rolled in from
        outside); ``"tet"`` keeps the tetrahedra whose circumsphere radius is ≤ alpha (the
        classic filter, right for volumetric clouds). For a cloud sampling only the surface,
        interior tets have circumradii comparable with the rock itself, so ``"tet"`` with alpha
        a few point spacings keeps a hollow shell; carving keeps the interior.
    closed_base : the carving ball cannot enter through convex-hull faces facing downward
        (outward normal z < -0.5): a scan's base is occluded by the pedestal, which closes it.
    max_tries : times alpha is raised by 25 % when the surface is not manifold before falling
        back to the convex hull.
    """
    p = np.asarray(points, dtype=np.float64)
    check_points(p, name)
    if len(p) < MIN_CLOUD_POINTS:
        raise GeometryError(
            f"{name}: only {len(p)} points; expected at least {MIN_CLOUD_POINTS} to reconstruct a closed "
            "surface (a scan of the whole rock)"
        )
    for what, v in (("alpha_multiple", alpha_multiple), ("alpha", alpha)):
        if v is not None and not (math.isfinite(float(v)) and float(v) > 0):
            raise GeometryError(f"{name}: {what} {v!r}: expected a positive number")
    spacing = median_spacing(p)
    if alpha is None:
        alpha_multiple = DEFAULT_ALPHA_MULTIPLE if alpha_multiple is None else float(alpha_multiple)
        alpha = alpha_multiple * spacing
    else:
        alpha_multiple = float(alpha) / spacing
    try:
        dl = Delaunay(p)
    except Exception as exc:
        raise GeometryError(
            f"{name}: Delaunay tetrahedralisation failed ({exc}); expected a 3-D point set"
        ) from None
    radii = circumradii(p, dl.simplices)
    face_radii = face_circumradii(p, dl.simplices) if criterion == "carve" else radii
    down = _downward_hull_faces(p, dl)
    warnings: list[str] = []
    hull_volume = float(ConvexHull(p).volume)
    a = float(alpha)
    for attempt in range(max_tries + 1):
        kept = _select(dl, radii, face_radii, a, criterion, closed_base, down)
        if kept.any():
            kept, mesh, n_fixed = _fill_pinches(p, dl, kept)
            if n_fixed:
                warnings.append(
                    f"alpha = {a:.4g} m: filled the tetrahedra around {n_fixed} non-manifold edge(s)"
                )
            leaked = mesh.volume < MIN_HULL_FRACTION * hull_volume
            if leaked:
                warnings.append(
                    f"alpha = {a:.4g} m leaked through a gap in the scan (solid {mesh.volume:.4g} m³ < "
                    f"{MIN_HULL_FRACTION:.0%} of the hull {hull_volume:.4g} m³); raising alpha"
                )
            elif mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0:
                if attempt:
                    warnings.append(
                        f"alpha raised from {alpha:.4g} m to {a:.4g} m to obtain a manifold surface"
                    )
                return AlphaSolid(p, dl, kept, a, a / spacing, spacing, mesh, "alpha", warnings)
        a *= 1.25
    hull = ConvexHull(p)
    kept = np.ones(len(dl.simplices), bool)
    mesh = trimesh.Trimesh(vertices=p, faces=hull.simplices, process=False)
    fix_winding(mesh)
    if mesh.volume < 0:
        mesh.invert()
    mesh.remove_unreferenced_vertices()
    warnings.append(
        f"the alpha shape was not manifold up to alpha = {a / 1.25:.4g} m; fell back to the convex hull "
        "(overestimates the volume of concave rocks)"
    )
    return AlphaSolid(p, dl, kept, float("inf"), float("inf"), spacing, mesh, "convex_hull", warnings)


def reconstruction_sensitivity(
    points: np.ndarray,
    *,
    alpha_multiples: tuple[float, ...] = (6.0, 8.0, 10.0),
    spacings: tuple[float, ...] | None = None,
    density: float = 2700.0,
) -> dict[str, Any]:
    """Volume, COM and inertia over alpha multiples × grid spacings, with relative spreads.

    Each row holds the exact (mesh) values and the node estimate at each spacing. Spreads:
    ``(max - min) / mean`` of volume and of the principal moments, and the largest COM
    distance from the mean COM over the rock size, across all rows.
    """
    from pbr_xval.geometry.mass import exact_mass_properties, node_mass_properties

    p = np.asarray(points, dtype=np.float64)
    size = float(np.ptp(p, axis=0).max())
    if spacings is None:
        spacings = (size / 30, size / 45)
    rows: list[dict[str, Any]] = []
    for am in alpha_multiples:
        sol = alpha_solid(p, alpha_multiple=am)
        ex = exact_mass_properties(sol.mesh, density=density)
        rows.append(
            {
                "alpha_multiple": am,
                "alpha_m": sol.alpha,
                "method": f"exact ({sol.method})",
                "spacing_m": None,
                "volume_m3": ex.volume,
                "com_m": ex.com.tolist(),
                "principal_moments": ex.principal_moments.tolist(),
                "warnings": sol.warnings,
            }
        )
        for h in spacings:
            nd = node_mass_properties(sol.grid_nodes(h), h, density=density)
            rows.append(
                {
                    "alpha_multiple": am,
                    "alpha_m": sol.alpha,
                    "method": "nodes",
                    "spacing_m": h,
                    "volume_m3": nd.volume,
                    "com_m": nd.com.tolist(),
                    "principal_moments": nd.principal_moments.tolist(),
                    "warnings": [],
                }
            )

    def spread(vals: np.ndarray) -> float:
        return float((vals.max(0) - vals.min(0)).max() / np.abs(vals.mean(0)).min()) if len(vals) else 0.0

    vols = np.array([r["volume_m3"] for r in rows])
    coms = np.array([r["com_m"] for r in rows])
    pm = np.array([r["principal_moments"] for r in rows])
    ex_rows = [r for r in rows if r["spacing_m"] is None]
    return {
        "rows": rows,
        "volume_spread": spread(vols[:, None]),
        "volume_spread_exact": spread(np.array([[r["volume_m3"]] for r in ex_rows])),
        "com_spread_over_size": float(np.linalg.norm(coms - coms.mean(0), axis=1).max() / size),
        "principal_moment_spread": float(((pm.max(0) - pm.min(0)) / pm.mean(0)).max()),
    }
