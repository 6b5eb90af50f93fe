"""Scene reductions: a decimated collision mesh that keeps the base, and basal contact nodes."""

from __future__ import annotations

from typing import Any

import numpy as np
import trimesh
from scipy.spatial import ConvexHull

__all__ = ["basal_nodes", "decimate_keep_base", "manifold_repair"]


def decimate_keep_base(mesh: trimesh.Trimesh, cell: float, band: float) -> trimesh.Trimesh:
    """Vertex-clustering decimation away from the base; the basal band keeps full resolution.

    Vertices higher than ``min z + band`` (m) are snapped to the centroid of their cell in a
    grid of size ``cell`` (m); faces that collapse are dropped. Vertices in the band are untouched,
    so the contact geometry is exactly the original's.

    Clustering can leave non-manifold edges (three or four faces on one edge, two faces with the
    same edge direction) and small holes, which engines reject: MuJoCo refuses a mesh whose faces
    have "inconsistent orientation" (a directed edge used twice) for its exact inertia.
    :func:`manifold_repair` removes the faces at those edges and closes the holes with fans of
    the existing vertices, so the result is closed and consistently oriented (no vertex moves).
    """
    v = np.asarray(mesh.vertices, dtype=float)
    zmin = v[:, 2].min()
    high = v[:, 2] > zmin + band
    keys = np.floor((v - v.min(axis=0)) / cell).astype(np.int64)
    # one cluster id per high vertex cell; band vertices keep their own id
    _, cluster = np.unique(keys[high], axis=0, return_inverse=True)
    new_id = np.arange(len(v))
    hi_idx = np.nonzero(high)[0]
    new_id[hi_idx] = len(v) + cluster.ravel()
    uniq, remap = np.unique(new_id, return_inverse=True)
    sums = np.zeros((len(uniq), 3))
    np.add.at(sums, remap, v)
    counts = np.bincount(remap, minlength=len(uniq)).astype(float)
    nv = sums / counts[:, None]
    f = remap[np.asarray(mesh.faces)]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    out = trimesh.Trimesh(vertices=nv, faces=f[keep], process=True)
    out.update_faces(out.unique_faces())
    out.remove_unreferenced_vertices()
    faces = manifold_repair(len(out.vertices), np.asarray(out.faces, dtype=np.int64))
    out = trimesh.Trimesh(vertices=np.asarray(out.vertices), faces=faces, process=False)
    out.remove_unreferenced_vertices()
    if out.volume < 0:  # the input was inward: keep the decimated surface outward like a closed rock
        out.invert()
    return out


def _edges(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directed edges (3m, 2) of faces (m, 3) and the face of each."""
    return np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), np.tile(np.arange(len(f)), 3)


def _boundary_loops(edges: np.ndarray) -> list[list[int]]:
    """Simple cycles of the boundary's directed edges (a vertex met twice splits a cycle)."""
    nxt: dict[int, list[int]] = {}
    for a, b in edges.tolist():
        nxt.setdefault(a, []).append(b)
    loops: list[list[int]] = []
    for start in sorted(nxt):
        while nxt[start]:
            path, pos, cur = [start], {start: 0}, start
            while nxt.get(cur):
                b = nxt[cur].pop(0)
                if b in pos:  # a cycle closes at b: cut it out and go on from b
                    p = pos[b]
                    if len(path) - p >= 3:
                        loops.append(path[p:])
                    for x in path[p + 1 :]:
                        del pos[x]
                    del path[p + 1 :]
                else:
                    pos[b] = len(path)
                    path.append(b)
                cur = b
    return loops


def manifold_repair(n_vertices: int, faces: np.ndarray, max_rounds: int = 20) -> np.ndarray:
    """Faces (k, 3) of a closed, consistently oriented surface from nearly manifold ``faces`` (m, 3).

    Each round removes the faces on a bad edge (a directed edge of two faces, or an undirected
    edge of four or more), growing the removed region by one ring of faces per round while
    bad edges persist, then closes every boundary cycle with a fan of its own vertices (oriented
    against the boundary, so every directed edge appears once and its reverse once). Deterministic.
    Raises ``ValueError`` when ``max_rounds`` rounds do not converge.
    """
    f = np.asarray(faces, dtype=np.int64)
    n = int(n_vertices)
    for rnd in range(max_rounds):
        e, fi = _edges(f)
        dk = e[:, 0] * n + e[:, 1]
        uk = np.minimum(e[:, 0], e[:, 1]) * n + np.maximum(e[:, 0], e[:, 1])
        _, dinv, dc = np.unique(dk, return_inverse=True, return_counts=True)
        _, uinv, uc = np.unique(uk, return_inverse=True, return_counts=True)
        # a directed edge of two faces; four faces on an edge, two each way (three faces always
        # repeat a direction)
        bad = (dc[dinv.ravel()] > 1) | (uc[uinv.ravel()] > 3)
        boundary = ~np.isin(e[:, 1] * n + e[:, 0], dk)
        if not bad.any() and not boundary.any():
            return f
        if bad.any():
            drop = np.zeros(len(f), dtype=bool)
            drop[fi[bad]] = True
            for _ in range(rnd):  # the repair did not converge: a wider region
                drop |= np.isin(f, np.unique(f[drop])).any(axis=1)
            f = f[~drop]
            e, _ = _edges(f)
            boundary = ~np.isin(e[:, 1] * n + e[:, 0], e[:, 0] * n + e[:, 1])
        new: list[Any] = [
            (loop[0], loop[i + 1], loop[i])
            for loop in _boundary_loops(e[boundary])
            for i in range(1, len(loop) - 1)
        ]
        if new:
            f = np.vstack([f, np.asarray(new, dtype=np.int64)])
    raise ValueError(f"manifold_repair: not a closed oriented surface after {max_rounds} rounds")


def basal_nodes(
    vertices: np.ndarray, com: np.ndarray, count: int | None = None, band: float | None = None
) -> np.ndarray:
    """Contact nodes (k, 3) on the rock for a rigid-contact solver against a flat pedestal.

    ``count=None``: the convex-hull vertices below the centre of mass (only those can touch a
    flat pedestal before the rock tips past horizontal). With ``count``: the support polygon
    (hull points within ``band`` of the lowest point) is filled with a regular grid of about
    ``count`` nodes (always including the polygon's corners), the basal patch a seed-style
    node model would use.
    """
    from pbr_xval.geometry.stability import hull_vertices

    v = np.asarray(vertices, dtype=float)
    # the hull's vertices only (hull_vertices keeps every point of a set of ≤ 16, e.g. a notched
    # block's concave corners, which must not become nodes); above that, memoised per mesh
    hv = hull_vertices(v) if len(v) > 16 else v[ConvexHull(v).vertices]
    if count is None:
        return hv[hv[:, 2] < com[2]]
    zmin = hv[:, 2].min()
    band = band if band is not None else 1e-6 * max(1.0, float(np.ptp(v)))
    base = hv[hv[:, 2] <= zmin + band]
    xy = base[:, :2]
    if len(base) >= 3:
        poly = xy[ConvexHull(xy).vertices]
    else:
        poly = xy
    corners = np.column_stack([poly, np.full(len(poly), zmin)])
    n_fill = max(count - len(corners), 0)
    if n_fill == 0 or len(poly) < 3:
        return corners[:count] if count < len(corners) else corners
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    from matplotlib.path import Path as MplPath

    path = MplPath(poly)
    area = 0.5 * abs(np.dot(poly[:, 0], np.roll(poly[:, 1], 1)) - np.dot(poly[:, 1], np.roll(poly[:, 0], 1)))
    h = np.sqrt(area / max(n_fill, 1))
    for _ in range(30):
        gx = np.arange(lo[0] + h / 2, hi[0], h)
        gy = np.arange(lo[1] + h / 2, hi[1], h)
        pts = np.stack(np.meshgrid(gx, gy, indexing="ij"), axis=-1).reshape(-1, 2)
        inside = pts[path.contains_points(pts, radius=-1e-12)]
        if len(inside) >= n_fill:
            break
        h *= 0.95
    if len(inside) > n_fill:
        inside = inside[np.round(np.linspace(0, len(inside) - 1, n_fill)).astype(int)]
    fill = np.column_stack([inside, np.full(len(inside), zmin)])
    return np.vstack([corners, fill])
