"""Rock, pedestal and their contact interface; resting pose; critical tilt for every direction.

* :func:`split_by_plane` — one scan cut by a plane into the rock (above) and pedestal (below).
* :func:`fit_plane`, :func:`pedestal_plane` — the pedestal top near the rock, by least squares.
* :func:`contact_patch` — the seed's basal contact points: rock points (surface vertices and/or
  grid nodes) within ε of the pedestal surface, their support polygon (2-D convex hull in the
  pedestal plane, area) and minimum-area bounding rectangle (shapely).
* :func:`rest_pose` — the resting pose on a flat pedestal, one vocabulary for ``pbr-xval rock``
  and scenarios (:data:`POSES`, default :data:`DEFAULT_POSE`): ``scan`` keeps the scan's
  orientation (lowest point on z = 0) and is refused with :class:`NotAtRestError` when the COM is
  not over its support there; ``settle`` (:func:`settle_pose`) lets the rock settle from its scan
  orientation onto the hull face below its COM (identical to ``scan`` when the scan pose is at
  rest); ``stable`` (:func:`stable_pose`) is the orientation with the lowest centre of mass over
  the convex hull's faces (the hull face nearest the COM, which is always stable).
* :func:`stability_table`, :func:`plot_stability_polar` — α(φ) and g·tan α(φ) for every
  horizontal direction φ, and their polar plot.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import ArrayLike
from scipy.spatial import ConvexHull, cKDTree

from pbr_xval.geometry.io import GeometryError
from pbr_xval.geometry.stability import StabilityTable, hull_vertices

__all__ = [
    "DEFAULT_POSE",
    "PHI_CONVENTION",
    "POSES",
    "ContactPatch",
    "NotAtRestError",
    "contact_patch",
    "distance_to_mesh",
    "fit_plane",
    "frame_from_plane",
    "load_rock_mesh",
    "pedestal_plane",
    "plot_stability_polar",
    "rest_pose",
    "scan_pose",
    "settle_pose",
    "split_by_plane",
    "stability_table",
    "stable_pose",
]


# ------------------------------------------------------------------------------------- planes
def fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares plane (centroid (3,), unit normal (3,) with n_z ≥ 0) through ``points``."""
    p = np.asarray(points, float)
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    n = vt[2]
    if n[2] < 0:
        n = -n
    return c, n / np.linalg.norm(n)


def frame_from_plane(point: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """4×4 rigid transform taking the plane to z = 0 with ``normal`` → +z (minimal rotation)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(n, z)
    s, c = np.linalg.norm(v), float(n @ z)
    if s < 1e-15:
        r = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / s
        ang = np.arctan2(s, c)
        r = np.eye(3) + np.sin(ang) * k + (1 - np.cos(ang)) * (k @ k)
    t = np.eye(4)
    t[:3, :3] = r
    t[:3, 3] = -r @ np.asarray(point, float)
    return t


def pedestal_plane(
    pedestal_points: np.ndarray, rock_points: np.ndarray, radius: float | None = None
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Plane fitted to the pedestal top near the rock's base.

    Uses the pedestal points within ``radius`` (default 25 % of the rock's horizontal size) of
    the rock's lowest 10 % of points (horizontal distance) and above the pedestal's median
    height there; two passes of 2.5-σ outlier rejection. Returns (point, normal, info).
    """
    ped = np.asarray(pedestal_points, float)
    rock = np.asarray(rock_points, float)
    zr = rock[:, 2]
    base = rock[zr <= zr.min() + 0.1 * np.ptp(zr)]
    if radius is None:
        radius = 0.25 * float(np.ptp(rock[:, :2], axis=0).max())
    d, _ = cKDTree(base[:, :2]).query(ped[:, :2], k=1)
    near = ped[d <= radius]
    if len(near) < 3:
        raise GeometryError(
            f"only {len(near)} pedestal points lie within {radius:.3g} m of the rock's base; "
            "expected a pedestal scanned under the rock"
        )
    near = near[near[:, 2] >= np.median(near[:, 2]) - 1e-12] if len(near) > 20 else near
    c, n = fit_plane(near)
    for _ in range(2):
        r = (near - c) @ n
        keep = np.abs(r) <= 2.5 * max(r.std(), 1e-12)
        if keep.sum() >= 3:
            near = near[keep]
            c, n = fit_plane(near)
    rms = float(np.sqrt(np.mean(((near - c) @ n) ** 2)))
    return c, n, {"n_points": len(near), "rms_m": rms, "radius_m": radius}


def distance_to_mesh(
    points: np.ndarray, mesh: trimesh.Trimesh, n_samples: int = 200_000, seed: int = 0
) -> np.ndarray:
    """Approximate unsigned distance from ``points`` to ``mesh`` (nearest of vertices + surface samples).

    (trimesh.proximity needs rtree, which this project does not require.)
    """
    samples = trimesh.sample.sample_surface(mesh, n_samples, seed=seed)[0]
    tree = cKDTree(np.vstack([mesh.vertices, samples]))
    return tree.query(np.asarray(points, float), k=1)[0]


# ------------------------------------------------------------------------------------- cutting
def split_by_plane(
    geom: trimesh.Trimesh | np.ndarray, point: np.ndarray, normal: ArrayLike = (0.0, 0.0, 1.0)
) -> tuple[Any, Any]:
    """Split a closed mesh (capped) or a point cloud into (above, below) the plane."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    o = np.asarray(point, float)
    if isinstance(geom, trimesh.Trimesh):
        from pbr_xval.geometry.io import fill_small_holes

        parts = []
        for side in (n, -n):
            # cap=True would triangulate the cut with networkx (not a dependency): slice open, then cap
            # each planar cut loop with a fan (exact signed volume and ray parity for any simple loop)
            part = trimesh.intersections.slice_mesh_plane(geom, side, o, cap=False)
            if part is not None and len(part.faces):
                part.merge_vertices()
                part.update_faces(part.nondegenerate_faces())
                part.remove_unreferenced_vertices()
                if not part.is_watertight:
                    fill_small_holes(part, max_area_fraction=np.inf)
            parts.append(part)
        above, below = parts
        for part, what in ((above, "above"), (below, "below")):
            if part is not None and len(part.faces) and not part.is_watertight:
                raise GeometryError(
                    f"the cut plane through {o.tolist()} leaves an open surface {what} it (its cut could not "
                    "be capped); expected a closed scan cut once"
                )
            if part is None or len(part.faces) == 0 or not part.volume > 0:
                raise GeometryError(
                    f"the cut plane through {o.tolist()} leaves nothing {what} it; expected a cut through the scan"
                )
        return above, below
    p = np.asarray(geom, float)
    s = (p - o) @ n
    return p[s >= 0], p[s < 0]


# ------------------------------------------------------------------------------------- contact
@dataclass
class ContactPatch:
    """Basal contact of the rock on the pedestal plane (in the frame of the points given).

    Attributes
    ----------
    points : (k, 3) rock points within ``eps`` of the plane.
    plane_point, plane_normal : the pedestal plane.
    eps : tolerance (m).
    polygon : (q, 2) support polygon vertices (counter-clockwise) in plane coordinates (u, v).
    area : support polygon area (m²).
    rectangle : {"center": (2,), "extents": (2,), "angle_deg"} minimum-area bounding rectangle.
    basis : (2, 3) unit vectors u, v spanning the plane.
    """

    points: np.ndarray
    plane_point: np.ndarray
    plane_normal: np.ndarray
    eps: float
    polygon: np.ndarray
    area: float
    rectangle: dict[str, Any]
    basis: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        """The contact patch as plain JSON values (points in m, areas in m²)."""
        return {
            "n_points": len(self.points),
            "eps_m": self.eps,
            "plane_point_m": self.plane_point.tolist(),
            "plane_normal": self.plane_normal.tolist(),
            "support_polygon_uv_m": self.polygon.tolist(),
            "area_m2": self.area,
            "min_rectangle": self.rectangle,
        }


def _plane_basis(n: np.ndarray) -> np.ndarray:
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u -= (u @ n) * n
    u /= np.linalg.norm(u)
    if abs(n[2]) > 0.9:  # keep u near +x for a horizontal plane
        u = np.array([1.0, 0.0, 0.0]) - n[0] * n
        u /= np.linalg.norm(u)
    v = np.cross(n, u)
    return np.vstack([u, v])


def contact_patch(
    rock_points: np.ndarray,
    plane_point: np.ndarray | None = None,
    plane_normal: ArrayLike = (0.0, 0.0, 1.0),
    eps: float | None = None,
) -> ContactPatch:
    """Rock points within ``eps`` of the pedestal plane and their support polygon.

    ``plane_point`` defaults to the lowest rock point (a flat pedestal under the scan pose);
    ``eps`` defaults to 0.5 % of the rock's size. Points below the plane (interpenetration in
    the scan) count as in contact.
    """
    from shapely.geometry import MultiPoint

    p = np.asarray(rock_points, float)
    n = np.asarray(plane_normal, float) / np.linalg.norm(plane_normal)
    size = float(np.ptp(p, axis=0).max())
    if plane_point is None:
        plane_point = p[np.argmin(p @ n)]
    o = np.asarray(plane_point, float)
    if eps is None:
        eps = 0.005 * size
    h = (p - o) @ n
    pts = p[h <= eps]
    if len(pts) == 0:
        raise GeometryError(
            f"no rock point lies within {eps:.3g} m of the pedestal plane (lowest is {h.min():.3g} m above); "
            "expected the rock to rest on the pedestal"
        )
    basis = _plane_basis(n)
    uv = (pts - o) @ basis.T
    hull = MultiPoint([tuple(q) for q in uv]).convex_hull
    if hull.geom_type == "Polygon":
        poly = np.asarray(hull.exterior.coords)[:-1]
        if hull.exterior.is_ccw is False:
            poly = poly[::-1]
        rect = hull.minimum_rotated_rectangle
        rc = np.asarray(rect.exterior.coords)[:4]
        e1, e2 = rc[1] - rc[0], rc[2] - rc[1]
        rectangle = {
            "center": rc.mean(axis=0).tolist(),
            "extents": sorted([float(np.linalg.norm(e1)), float(np.linalg.norm(e2))], reverse=True),
            "angle_deg": float(np.degrees(np.arctan2(e1[1], e1[0]))) % 180.0,
        }
        area = float(hull.area)
    else:
        poly = np.asarray(hull.coords) if hull.geom_type != "Point" else np.asarray([hull.coords[0]])
        ext = float(np.ptp(poly, axis=0).max()) if len(poly) > 1 else 0.0
        rectangle = {"center": poly.mean(axis=0).tolist(), "extents": [ext, 0.0], "angle_deg": 0.0}
        area = 0.0
    return ContactPatch(pts, o, n, float(eps), poly, area, rectangle, basis)


# ------------------------------------------------------------------------------------- poses
#: the resting poses, for ``pbr-xval rock --pose`` and the scenario key ``rock.pose``
POSES = ("scan", "settle", "stable")
DEFAULT_POSE = "settle"


class NotAtRestError(GeometryError):
    """The rock cannot rest in the requested pose (its COM is not over its support)."""


def rest_pose(
    vertices: np.ndarray, com: np.ndarray, pose: str = DEFAULT_POSE, *, hint: str = "use pose = settle"
) -> tuple[np.ndarray, dict[str, Any]]:
    """4×4 transform putting the rock (vertices (n, 3) m, COM (3,) m) at rest in ``pose``.

    Returns (transform, info) with info["pose"] = ``pose`` and the pose's details.

    Raises
    ------
    NotAtRestError
        ``scan`` when the COM's vertical misses the support of the scan orientation; the message
        says by how much, how far settling would tilt the rock, and ends with ``hint``.
    GeometryError
        an unknown ``pose``.
    """
    from pbr_xval.geometry.stability import rest_margin, support_polygon

    v = np.asarray(vertices, float)
    c = np.asarray(com, float)
    if pose == "scan":
        t = scan_pose_vertices(v)
        pts = v + t[:3, 3]
        margin = rest_margin(support_polygon(pts), c[:2])
        if margin <= 0:
            tilt = settle_pose(v, c)[1]["tilt_deg"]
            raise NotAtRestError(
                "the rock is not at rest in its scan pose: its COM is outside its support "
                f"(the COM's vertical passes {-margin * 1e3:.3g} mm outside the support polygon of the scan's "
                f"lowest points; settling onto the hull face below the COM tilts it by {tilt:.3g}°); {hint}"
            )
        return t, {"pose": "scan", "rest_margin_m": margin}
    if pose == "settle":
        t, info = settle_pose(v, c)
        return t, {"pose": "settle", **info}
    if pose == "stable":
        t, info = stable_pose(v, c)
        return t, {"pose": "stable", **info}
    raise GeometryError(f"pose {pose!r}: expected one of {', '.join(POSES)}")


def scan_pose_vertices(vertices: np.ndarray) -> np.ndarray:
    """4×4 transform keeping the orientation of ``vertices`` (n, 3), lowest point on z = 0."""
    t = np.eye(4)
    t[2, 3] = -float(np.asarray(vertices, float)[:, 2].min())
    return t


def scan_pose(mesh: trimesh.Trimesh) -> np.ndarray:
    """4×4 transform keeping the scan's orientation, lowest point on z = 0."""
    t = np.eye(4)
    t[2, 3] = -float(mesh.vertices[:, 2].min())
    return t


def stable_pose(vertices: np.ndarray, com: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
    """The resting orientation with the lowest centre of mass on a flat pedestal.

    Among the convex hull's faces (coplanar triangles merged), the plane nearest the COM is
    always a stable resting face (the COM projects inside it). Returns the 4×4 transform that
    puts that face on z = 0 with the rock above, and {"face_normal", "com_height_m",
    "face_vertices", "n_hull_faces"}.
    """
    v = np.asarray(vertices, float)
    hull = ConvexHull(v)
    eq = hull.equations  # n·x + d <= 0 inside, n outward
    dist = -(eq[:, :3] @ np.asarray(com, float) + eq[:, 3])
    i = int(np.argmin(dist))
    n = eq[i, :3]
    # the resting face: hull vertices on that plane
    on = np.abs(v @ n + eq[i, 3]) <= 1e-9 * float(np.ptp(v)) + 1e-12
    t = frame_from_plane(v[on][0], -n)  # outward normal → -z, so the rock sits above
    rotated = trimesh.transform_points(v, t)
    t[2, 3] -= float(rotated[:, 2].min())
    return t, {
        "face_normal": n.tolist(),
        "com_height_m": float(dist[i]),
        "face_vertices": int(on.sum()),
        "n_hull_faces": len(eq),
    }


def settle_pose(
    vertices: np.ndarray, com: np.ndarray, max_iter: int = 20
) -> tuple[np.ndarray, dict[str, Any]]:
    """Settle the rock from its current orientation onto the hull face below its COM.

    The vertical through the COM leaves the convex hull through one face; that face is rotated
    onto z = 0 and the step repeated until the face stays the same (the COM is then above it).
    A rock already at rest in its current orientation (the COM's vertical strictly inside the
    support polygon of its lowest points) is left as it is (only lowered onto z = 0).
    Returns the 4×4 transform and {"face_normal", "iterations", "tilt_deg"}.
    """
    from pbr_xval.geometry.stability import rest_margin, support_polygon

    v0 = np.asarray(vertices, float)
    hv = hull_vertices(v0)
    c = np.asarray(com, float)
    if rest_margin(support_polygon(hv), c[:2]) > 0:
        return scan_pose_vertices(v0), {"face_normal": [0.0, 0.0, -1.0], "iterations": 0, "tilt_deg": 0.0}
    total = np.eye(4)
    prev = None
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported
        pts = trimesh.transform_points(hv, total)
        cc = trimesh.transform_points(c[None], total)[0]
        eq = ConvexHull(pts).equations
        down = eq[:, 2] < -1e-12
        t = -(eq[down, :3] @ cc + eq[down, 3]) / (-eq[down, 2])  # ray cc + t(-z)
        i = int(np.argmin(t))
        n = eq[down][i, :3]
        if prev is not None and np.allclose(n, [0, 0, -1], atol=1e-10):
            break
        step = frame_from_plane(cc + t[i] * np.array([0, 0, -1.0]), -n)
        total = step @ total
        prev = n
    pts = trimesh.transform_points(v0, total)
    total[2, 3] -= float(pts[:, 2].min())
    tilt = float(np.degrees(np.arccos(np.clip(total[2, 2], -1, 1))))
    return total, {
        "face_normal": (-total[:3, :3].T @ [0, 0, 1.0]).tolist(),
        "iterations": it,
        "tilt_deg": tilt,
    }


# ------------------------------------------------------------------------------------- stability
def stability_table(vertices: np.ndarray, com: np.ndarray, n_directions: int = 72) -> StabilityTable:
    """:class:`StabilityTable` of the rock at rest on z = min z (vertices (n, 3) m, COM (3,) m)."""
    return StabilityTable(np.asarray(vertices, float), np.asarray(com, float), n_directions=n_directions)


def _atomic_savefig(fig: Any, path: Path, **kw: Any) -> None:
    from pbr_xval.atomic import write_figure_atomic

    write_figure_atomic(path, fig, **kw)


#: how φ is measured, stated on every polar plot
PHI_CONVENTION = "φ = 0 along +x; φ grows counter-clockwise seen from above (+x toward +y)"


def plot_stability_polar(table: StabilityTable, path: str | Path, g: float = 9.81, title: str = "") -> Path:
    """Polar plot of α(φ), α_u(φ) (deg) and g·tan α_u(φ) (m/s²) written atomically to ``path`` (PNG).

    Directions where the pose is not at rest (NaN) are left as gaps; the φ convention
    (:data:`PHI_CONVENTION`) is written on the figure.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    phi = np.append(table.phi, table.phi[0] + 2 * np.pi)
    alpha = np.degrees(np.append(table.alpha, table.alpha[0]))
    alpha_u = np.degrees(np.append(table.uplift_angle, table.uplift_angle[0]))
    acc = np.append(table.toppling_accel(g), table.toppling_accel(g)[0])
    fig, axes = plt.subplots(1, 2, subplot_kw={"projection": "polar"}, figsize=(10, 5.4))
    axes[0].plot(
        phi, alpha, "-o", ms=2, label="critical tilt α (turned about the horizontal axis normal to φ)"
    )
    axes[0].plot(phi, alpha_u, "-", lw=1.2, color="C2", label="tilt-table angle α_u = atan(ρ/h_G)")
    axes[0].set_title("tilt angles toward φ [deg]")
    fig.legend(loc="lower center", bbox_to_anchor=(0.5, 0.03), ncol=2, fontsize=7)
    axes[1].plot(phi, acc, "-o", ms=2, color="C3")
    axes[1].set_title("quasi-static uplift g·tan α_u(φ) [m/s²]\n(a lower bound on the toppling PGA)")
    for ax in axes:
        ax.set_theta_zero_location("E")
        ax.set_theta_direction(1)
        ax.set_rmin(0.0)
    fig.text(0.5, 0.012, PHI_CONVENTION, ha="center", fontsize=8)
    if not np.all(np.isfinite(table.alpha)):
        fig.text(
            0.5, 0.09, "gaps: no critical tilt (the pose is not at rest toward φ)", ha="center", fontsize=8
        )
    if title:
        fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    _atomic_savefig(fig, Path(path), dpi=110)
    plt.close(fig)
    return Path(path)


def load_rock_mesh(
    path: str | Path, *, units: str = "m", pose: str = "settle", hint: str = "use pose = settle"
) -> tuple[trimesh.Trimesh, dict[str, Any]]:
    """Load a closed rock mesh ready for mass properties (positive volume, consistent winding),
    put at rest in ``pose`` (``scan``, ``settle`` or ``stable``; see
    :func:`pbr_xval.geometry.interface.rest_pose`), lowest point on z = 0.

    Raises
    ------
    NotAtRestError
        ``pose = "scan"`` and the rock is not at rest in its scan orientation (the message
        names the file and ends with ``hint``).
    """
    import copy

    from pbr_xval.hashing import file_sha256

    # a campaign or a sweep compiles the same scan hundreds of times in one process: the loaded,
    # repaired and posed mesh is cached by the file's content (SHA-256) and the arguments, and
    # every caller gets its own copy (0.2–0.3 s per compile saved; same arrays bit for bit)
    mesh, info = _load_rock_mesh_cached(str(Path(path)), file_sha256(Path(path)), units, pose, hint)
    return mesh.copy(), copy.deepcopy(info)


@functools.lru_cache(maxsize=8)
def _load_rock_mesh_cached(
    path: str, sha256: str, units: str, pose: str, hint: str
) -> tuple[trimesh.Trimesh, dict[str, Any]]:
    """:func:`load_rock_mesh` for one file content (``sha256`` is the cache key's content part)."""
    from pbr_xval.geometry.io import close_and_orient
    from pbr_xval.geometry.mesh import load_mesh

    mesh, info = load_mesh(path, units=units)
    # safe repairs without networkx (capping small planar holes, BFS winding fix, inversion)
    close_and_orient(mesh, path, info["repairs"])
    try:
        tf, pinfo = rest_pose(mesh.vertices, mesh.center_mass, pose, hint=hint)
    except NotAtRestError as exc:
        raise NotAtRestError(f"{path}: {exc}") from None
    mesh.apply_transform(tf)
    info["pose_transform"] = np.asarray(tf).tolist()
    info["pose"] = pinfo
    return mesh, info
