"""Scene reductions: a decimated collision mesh that keeps the base, and basal contact nodes."""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import ConvexHull

__all__ = ["basal_nodes", "decimate_keep_base"]


def decimate_keep_base(mesh: trimesh.Trimesh, cell: float, band: float) -> trimesh.Trimesh:
    """Vertex-clustering decimation away from the base; the basal band keeps full resolution.

    Vertices higher than ``min z + band`` (m) are snapped to the centroid of their cell in a
    grid of size ``cell`` (m); faces that collapse are dropped. Vertices in the band are untouched,
    so the contact geometry is exactly the original's.
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
    return out


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
    v = np.asarray(vertices, dtype=float)
    hv = v[ConvexHull(v).vertices]
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
